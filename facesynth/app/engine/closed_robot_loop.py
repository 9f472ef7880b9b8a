"""A simulated head driven in process with T's loop closed through the head's own camera.

:class:`ClosedRobotLoop` is :class:`~facesynth.app.engine.robot_loop.RobotLoop` (T → C → the
head → its camera → the tracker → F) whose F output is also handed back to T
(:meth:`~facesynth.services.translator.core.Translator.observe`), as ``--robot-camera`` does
live: T's closed loop (:mod:`facesynth.services.translator.closed_loop`) corrects the next
frame's commands from the robot's face it saw, on the robot's clock. The head's camera image
of a frame is taken after that frame's command, so T sees each face one frame later, as a real
camera would show it. ``bench robot --closed-loop`` measures with it and ``render --robot-head
--closed-loop`` draws it.
"""

from __future__ import annotations

import msgspec
import numpy as np

from facesynth.app.engine.robot_loop import SETTLE_S, Head, RobotError, RobotLoop
from facesynth.runtime.calibration import Calibration
from facesynth.runtime.clock import FAKE_EPOCH_NS
from facesynth.runtime.profiles import Profile
from facesynth.schemas.messages import Features
from facesynth.services.points.backends.base import PointsBackend
from facesynth.services.translator.closed_loop import LoopOptions, LoopState

__all__ = ["ClosedRobotLoop"]


class ClosedRobotLoop(RobotLoop):
    """A :class:`~facesynth.app.engine.robot_loop.RobotLoop` whose translator sees the
    robot's own face; :class:`RobotError` (one line) for a profile that is not learned."""

    def __init__(
        self,
        profile: Profile,
        head: Head,
        *,
        fps: float,
        options: LoopOptions | None = None,
        state: LoopState | None = None,
        backend: PointsBackend | None = None,
        settle_s: float = SETTLE_S,
        calibration: Calibration | None = None,
    ) -> None:
        super().__init__(
            profile, head, fps=fps, backend=backend, settle_s=settle_s, calibration=calibration
        )
        try:
            self.loop = self.translator.close_loop(options, state)
        except ValueError as exc:
            raise RobotError(str(exc)) from None

    def step(self, performer: Features) -> tuple[np.ndarray, Features]:
        """Play one performer frame as :class:`RobotLoop` does (T's command, corrected by the
        faces seen so far → C → the head → its camera → F), then hand that face to T, stamped
        on T's clock (the stepped chain's wall clock: the robot's clock from
        :data:`~facesynth.runtime.clock.FAKE_EPOCH_NS`)."""
        image, features = super().step(performer)
        captured = FAKE_EPOCH_NS + features.t_capture_ns  # captured at the robot's now_ns
        self.translator.observe(msgspec.structs.replace(features, t_capture_ns=captured))
        return image, features
