"""What a command changes in the control core, kept until its hand-over to the driver.

:meth:`~facesynth.services.control.core.ControlCore.hand_over` judges a command's capture again
just before the driver writes; one that grew too old since it was taken is withdrawn, and the
core must then be exactly as before it: the servos' positions, velocities and catch-up, the
targets, the mode and ramp, the step and report times, the watchdog, and the sender's order
(so a command withdrawn counts neither as applied nor as the one the face follows).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

from facesynth.schemas.messages import ServoCommands

if TYPE_CHECKING:
    from facesynth.services.control.core import ControlCore
    from facesynth.services.control.neutral_return import Ramp


@dataclass(frozen=True, slots=True)
class Undo:
    """What a command changes in a :class:`~facesynth.services.control.core.ControlCore`, as
    it was before the command: restored when the command is withdrawn at the hand-over."""

    positions: dict[str, float]
    velocities: dict[str, float]
    catching_up: set[str]
    targets: dict[str, float]
    mode: Literal["idle", "follow", "return", "stop"]
    ramp: Ramp | None
    times: tuple[int | None, int | None, int | None]
    last_command: ServoCommands | None
    watchdog: tuple[int | None, bool]
    order: tuple[str | None, str, tuple[int, int] | None]

    @classmethod
    def of(cls, core: ControlCore, sender: str) -> Undo:
        """``core``'s state now, before a command of ``sender``."""
        motion = core.motion
        return cls(
            dict(motion.positions),
            dict(motion.velocities),
            set(motion.catching_up),
            core.targets,
            core.mode,
            core._ramp,
            (core._last_step_ns, core._last_report_ns, core._last_media_ns),
            core.last_command,
            (core.watchdog._last_ns, core.watchdog._fired),
            core.freshness.order_of(sender),
        )

    def restore(self, core: ControlCore) -> None:
        """Put ``core`` back as it was."""
        motion = core.motion
        motion.positions, motion.velocities = self.positions, self.velocities
        motion.catching_up = self.catching_up
        core.targets, core.mode, core._ramp = self.targets, self.mode, self.ramp
        core._last_step_ns, core._last_report_ns, core._last_media_ns = self.times
        core.last_command = self.last_command
        core.watchdog._last_ns, core.watchdog._fired = self.watchdog
        core.freshness.restore_order(self.order)
