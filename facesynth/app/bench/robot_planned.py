"""``bench robot --planned``: a learned profile's plan of the whole recorded performance
(``facesynth plan``, :mod:`facesynth.app.plan`) played through C onto a simulated head, in
process and in virtual time, beside the same profile driven by T frame by frame.

:class:`PlannedRobotLoop` is :class:`~.robot.RobotLoop` whose commands come from the plan
instead of T: each performer frame's planned command goes to C at that frame's instant, as
``facesynth replay PLAN --from servo_commands`` gives it to the control service (C clamps it
and limits its speed as it does T's), and the head's camera is tracked as for any run.
"""

from __future__ import annotations

import numpy as np

from facesynth.app.engine.robot_loop import Head, RobotLoop
from facesynth.app.plan.performance import plan_performance
from facesynth.runtime.clock import FAKE_EPOCH_NS
from facesynth.runtime.profiles import Profile
from facesynth.schemas.messages import Features, ServoCommands
from facesynth.services.control.freshness import Arrival

from .robot import Performance, play
from .robot_compare import FeatureStream

__all__ = ["PLANNED_SUFFIX", "PlannedRobotLoop", "run_planned"]

#: How a planned run of a profile is named beside its open-loop run.
PLANNED_SUFFIX = " (planned)"


class PlannedRobotLoop(RobotLoop):
    """A :class:`RobotLoop` playing ``commands`` (one per performer frame, in order) through
    C instead of T's; past the last one C gets none (its own moves go on: catching up, then
    its return to neutral when commands stop)."""

    def __init__(
        self, profile: Profile, head: Head, commands: list[ServoCommands], *, fps: float
    ) -> None:
        super().__init__(profile, head, fps=fps)
        self.commands = commands
        self.played = 0

    def step(self, performer: Features) -> tuple[np.ndarray, Features]:
        """Play the next planned command at ``performer``'s instant: the head's camera image
        and the robot's features."""
        if self.origin_ns is None:
            self.start()
        assert self.origin_ns is not None
        t_ns = max(self.now_ns, self.origin_ns + performer.t_media_ns)
        self._advance(t_ns)
        if self.played < len(self.commands):
            command = self.commands[self.played]
            self.played += 1
            move, _ = self.control.command(command, Arrival(FAKE_EPOCH_NS + t_ns, t_ns))
            self._send(move)
        self.now_ns = t_ns
        self.head.step(t_ns)
        image = self.head.render()
        return image, self._look(image)


def run_planned(performance: Performance, profile: Profile, head: Head) -> FeatureStream:
    """The robot's raw features for every performer frame with ``profile``'s plan of the
    whole performance played (no lead)."""
    plan = plan_performance(profile, performance.features)
    loop = PlannedRobotLoop(profile, head, plan.commands(), fps=performance.fps)
    return play(performance, loop)
