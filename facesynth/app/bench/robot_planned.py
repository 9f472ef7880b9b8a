"""``bench robot --planned``: a learned profile's plan of the whole recorded performance
(``facesynth plan``, :mod:`facesynth.app.plan`) played through C onto a simulated head, in
process and in virtual time, beside the same profile driven by T frame by frame.

:class:`PlannedRobotLoop` is :class:`~.robot.RobotLoop` whose commands come from the plan
instead of T: each performer frame's planned command goes to C at that frame's instant, as
``facesynth replay PLAN --from servo_commands`` gives it to the control service (C clamps it
and limits its speed as it does T's), and the head's camera is tracked as for any run.
"""

from __future__ import annotations

from facesynth.app.engine.robot_loop import Head, RobotLoop
from facesynth.app.plan.performance import plan_performance
from facesynth.runtime.clock import FAKE_EPOCH_NS
from facesynth.runtime.profiles import Profile
from facesynth.schemas.messages import Features, ServoCommands
from facesynth.services.control.core import Move
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

    def _move(self, performer: Features, t_ns: int) -> Move | None:
        """C's move for the next planned command at ``performer``'s instant (None past the
        plan's last)."""
        if self.played >= len(self.commands):
            return None
        command = self.commands[self.played]
        self.played += 1
        move, _ = self.control.command(command, Arrival(FAKE_EPOCH_NS + t_ns, t_ns))
        return move


def run_planned(performance: Performance, profile: Profile, head: Head) -> FeatureStream:
    """The robot's raw features for every performer frame with ``profile``'s plan of the
    whole performance played (no lead)."""
    plan = plan_performance(profile, performance.features)
    loop = PlannedRobotLoop(profile, head, plan.commands(), fps=performance.fps)
    return play(performance, loop)
