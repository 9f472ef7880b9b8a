"""Planning a recorded performance for a learned robot, offline (issue 27).

T plans each frame as it comes (:mod:`facesynth.services.translator`); a recorded video can be
planned whole. :mod:`.targets` gives T's targets for each frame, :mod:`.sequence` the commands
that follow the whole performance best by the likeness measure through the robot's
self-model, and :mod:`.performance` the servo commands of a planned performance, written as a
recording that ``facesynth replay --from servo_commands`` plays to a robot.
"""
