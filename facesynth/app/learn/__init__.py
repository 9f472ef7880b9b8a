"""``facesynth learn``: the robot learns its own face (babbling, self-model, inverse model).

* :mod:`.plan`: which pose comes next (sweeps of each servo alone, then space-filling random
  poses, a neutral every K poses, no extreme held long), deterministic given a seed;
* :mod:`.settle`: when a pose has settled (servos there, then the face still);
* :mod:`.core`: the babbler, pure, with time as data (pacing, settling, the face-lost pause,
  the budget, Ctrl-C back to neutral);
* :mod:`.shell`: the babbler on the bus with the robot's camera, tracker, features and control
  nodes and the recorder; :mod:`.progress`: the progress line;
* :mod:`.session`: the babbling session file (MCAP), read, resumed, turned into a
  :class:`~.dataset.BabbleSet`; :mod:`.sweeps`: dead servos and dead bands;
* :mod:`.dataset` and :mod:`.fit`: the data set and the fitting of the learned profile;
* :mod:`.cli`: the command.
"""
