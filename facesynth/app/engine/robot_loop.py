"""A simulated robot head driven in process: T → C → the head → its camera → tracker → F.

:class:`RobotLoop` runs one profile on one head in virtual time (T and C as the stepped chain
runs them, :class:`facesynth.app.engine.stepped.RobotCores`; the head's own dynamics stepped
to each move's instant; its camera image tracked and read by F as the performer's face is).
``facesynth bench robot`` measures likeness with it and ``facesynth render --robot-head``
draws the robot's side with it.
"""

from __future__ import annotations

from typing import Final, Protocol

import numpy as np

from facesynth.app.engine.stepped import RobotCores, sensor_frame
from facesynth.runtime.calibration import Calibration
from facesynth.runtime.profiles import Profile
from facesynth.schemas.messages import Features, Points
from facesynth.services.control.core import Move
from facesynth.services.features.core import FeatureProcessor
from facesynth.services.points.backends.base import PointsBackend
from facesynth.services.points.backends.tracker import TrackerBackend, TrackerConfig

__all__ = [
    "MODEL",
    "NEUTRAL_S",
    "NEUTRAL_TIMEOUT_S",
    "SETTLE_S",
    "Head",
    "RobotError",
    "RobotLoop",
    "robot_features",
    "tracker",
]

#: Tracker model watching both faces (the performer's and the robot's).
MODEL: Final = "full"
#: F's neutral window on both faces (seconds with a face).
NEUTRAL_S: Final = 1.0
#: Seconds the head is held at neutral before its neutral is measured (the head settles from
#: its rest, the tracker's crop settles).
SETTLE_S: Final = 1.0
#: Seconds after which a head at neutral without a face (or a neutral) is an error.
NEUTRAL_TIMEOUT_S: Final = 5.0


class RobotError(ValueError):
    """A head, profile or video a simulated robot cannot run with (``bench robot``, ``render
    --robot-head``); one line."""


class Head(Protocol):
    """What the loop needs of a simulated head (:class:`facesynth.app.simhead.SimHead`)."""

    def command(self, channel: int, pulse_us: float) -> None:
        """Set a channel's target pulse (µs)."""

    def step(self, t_ns: int) -> None:
        """Advance the actuators' dynamics to ``t_ns``."""

    def render(self) -> np.ndarray:
        """The head's camera image now (BGR)."""


def tracker(model: str = MODEL) -> TrackerBackend:
    """The tracker both faces are watched with (LiteRT when installed, blendshapes on)."""
    return TrackerBackend(TrackerConfig(model=model))


def robot_features(features: Features) -> dict[str, float] | None:
    """The raw values of one frame (``None`` without a face or before the neutral is known)."""
    if not features.face or not features.neutral_ready or not features.raw:
        return None
    return features.raw


class RobotLoop:
    """One profile driving one head in process: T → C → the head → its camera → tracker → F.

    Time is data: the robot's clock starts at 0 when C starts; :meth:`start` holds the head at
    neutral until F knows the robot's neutral, and each performer frame then plays at that
    instant plus its media time (:meth:`step`)."""

    def __init__(
        self,
        profile: Profile,
        head: Head,
        *,
        fps: float,
        backend: PointsBackend | None = None,
        settle_s: float = SETTLE_S,
        calibration: Calibration | None = None,
    ) -> None:
        if not fps > 0:
            raise RobotError("the frame rate must be positive")
        self.profile = profile
        self.head = head
        #: T and C as the stepped chain runs them (C on the robot's clock, in real time).
        self.cores = RobotCores.of_profile("robot", profile, calibration=calibration)
        self.translator = self.cores.translator
        self.control = self.cores.control
        self.channels = {spec.name: spec.channel for spec in profile.servos}
        self.backend = backend if backend is not None else tracker()
        self.processor = FeatureProcessor(neutral_seconds=NEUTRAL_S, neutral_held=True)
        self.period_ns = round(1e9 / fps)
        self.settle_ns = round(settle_s * 1e9)
        self.now_ns = 0
        self.seq = 0
        #: The points the tracker found on the head's last camera image.
        self.points: Points | None = None
        #: The robot's clock at the performer's media time 0 (known after :meth:`start`).
        self.origin_ns: int | None = None

    def start(self) -> Features:
        """Hold the head at the profile's neutral until F has learned the robot's neutral;
        the last frame's features (raise :class:`RobotError` if no face is seen)."""
        self._send(self.cores.start(0))
        limit = self.settle_ns + round(NEUTRAL_TIMEOUT_S * 1e9)
        while self.now_ns <= limit:
            self.now_ns += self.period_ns
            self._advance(self.now_ns)
            self.head.step(self.now_ns)
            points = self._points(self.head.render())
            if self.now_ns < self.settle_ns:
                continue  # the head and the tracker's crop settle; F does not see it yet
            features = self.processor.process(points)
            if robot_features(features) is not None:
                self.origin_ns = self.now_ns + self.period_ns
                return features
        raise RobotError(
            f"the tracker found no face (or no neutral) on the head held at "
            f"{self.profile.name}'s neutral within {limit / 1e9:.0f} s"
        )

    def step(self, performer: Features) -> tuple[np.ndarray, Features]:
        """Play one performer frame: the head's camera image and the robot's features."""
        if self.origin_ns is None:
            self.start()
        assert self.origin_ns is not None
        t_ns = max(self.now_ns, self.origin_ns + performer.t_media_ns)
        self._advance(t_ns)
        move = self._move(performer, t_ns)
        if move is not None:
            self._send(move)
        self.now_ns = t_ns
        self.head.step(t_ns)
        image = self.head.render()
        return image, self._look(image)

    def _move(self, performer: Features, t_ns: int) -> Move | None:
        """C's move for this performer frame at ``t_ns`` (None: no command reaches C): T's
        command for her features; a subclass may command C otherwise."""
        _, move = self.cores.command(performer, t_ns)
        return move

    def _advance(self, t_ns: int) -> None:
        """C's own moves (catch-up steps, returns) due up to ``t_ns``, sent as they happen."""
        for move in self.cores.advance(t_ns):
            self._send(move)

    def _send(self, move: Move) -> None:
        self.head.step(move.t_ns)
        for name, pulse in move.positions.items():
            try:
                self.head.command(self.channels[name], pulse)
            except ValueError as exc:  # e.g. a channel the head does not have
                raise RobotError(f"profile {self.profile.name}, servo {name}: {exc}") from None

    def _points(self, image: np.ndarray) -> Points:
        frame = sensor_frame(image, self.seq, self.now_ns, t_capture_ns=self.now_ns)
        self.seq += 1
        self.points = self.backend.process(frame)
        return self.points

    def _look(self, image: np.ndarray) -> Features:
        return self.processor.process(self._points(image))
