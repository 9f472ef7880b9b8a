"""When a babbling pose has settled: the servos got there, then the face held still.

Pure, time as data (monotonic ns). After a pose is commanded, :class:`Settle` waits until
``…/servo_state`` reports every servo within ``reach_tol_us`` of its command, then at least
``min_wait_s`` more (the skin lags the servo), then collects the face's raw features frame by
frame: the pose has settled when the last ``frames`` frames agree (the ``STEADY_QUANTILE`` of
their per-feature spans is within ``feature_tol``), or, ``max_wait_s`` after the servos got
there, with whatever the last frames were (``settled`` false). Servos that do not get there
within ``reach_timeout_s`` raise :class:`StalledError`.
"""

from __future__ import annotations

import collections
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

#: Which quantile of the features' spans over the window must be within the tolerance (a few
#: noisy features, such as gaze, must not hold every pose up).
STEADY_QUANTILE = 0.9


class SettleError(ValueError):
    """Settle options that cannot be used."""


class StalledError(RuntimeError):
    """The servos did not reach a commanded pose in time (the control interface does not follow
    the babbler: another profile, a stopped controller)."""


@dataclass(frozen=True)
class SettleOptions:
    """How long and how still a pose must be before it is taken."""

    reach_tol_us: float = 10.0
    feature_tol: float = 0.05
    frames: int = 4
    min_wait_s: float = 0.25
    max_wait_s: float = 3.0
    reach_timeout_s: float = 10.0

    def __post_init__(self) -> None:
        if self.frames < 1:
            raise SettleError("a pose settles over at least one frame")
        if not (self.reach_tol_us > 0 and self.feature_tol > 0):
            raise SettleError("the settle tolerances must be positive")
        if not 0 <= self.min_wait_s <= self.max_wait_s:
            raise SettleError("the settle waits need 0 <= minimum <= maximum")
        if not self.reach_timeout_s > 0:
            raise SettleError("the reach timeout must be positive")


@dataclass(frozen=True)
class Settled:
    """A settled pose: the face's mean raw features over the frames taken, their spread."""

    features: dict[str, float]
    spread: dict[str, float]
    frames: int
    settled: bool


def average(frames: Sequence[Mapping[str, float]]) -> tuple[dict[str, float], dict[str, float]]:
    """Per feature mean and standard deviation over frames (a feature absent from some frames
    is averaged over those that have it)."""
    names = sorted({name for frame in frames for name in frame})
    if not names:
        return {}, {}
    table = np.array([[frame.get(name, np.nan) for name in names] for frame in frames])
    count = np.sum(~np.isnan(table), axis=0)
    mean = np.nansum(table, axis=0) / count
    spread = np.sqrt(np.nansum((table - mean) ** 2, axis=0) / count)
    return (
        dict(zip(names, mean.tolist(), strict=True)),
        dict(zip(names, spread.tolist(), strict=True)),
    )


def steady(frames: Sequence[Mapping[str, float]], tolerance: float) -> bool:
    """Whether the frames agree: the STEADY_QUANTILE of per-feature spans is within tolerance."""
    names = sorted(set.intersection(*(set(frame) for frame in frames))) if frames else []
    if not names:
        return False
    table = np.array([[frame[name] for name in names] for frame in frames])
    spans = table.max(axis=0) - table.min(axis=0)
    return bool(np.quantile(spans, STEADY_QUANTILE) <= tolerance)


class Settle:
    """Follows one commanded pose until it settles (see the module docstring)."""

    def __init__(
        self, target: Mapping[str, float], commanded_ns: int, options: SettleOptions
    ) -> None:
        self.target = dict(target)
        self.options = options
        self.commanded_ns = commanded_ns
        self.reached_ns: int | None = None
        self.window: collections.deque[dict[str, float]] = collections.deque(maxlen=options.frames)
        self.result: Settled | None = None

    def servos(self, positions: Mapping[str, float], now_ns: int) -> None:
        """Where the control interface reports the servos."""
        if self.reached_ns is not None:
            return
        tol = self.options.reach_tol_us
        if all(
            abs(positions.get(name, -1e9) - value) <= tol for name, value in self.target.items()
        ):
            self.reached_ns = now_ns

    def face(self, raw: Mapping[str, float], now_ns: int) -> None:
        """One frame's raw features (a frame with a face)."""
        if self.result is not None or self.reached_ns is None:
            return
        if now_ns - self.reached_ns < self.options.min_wait_s * 1e9:
            return
        self.window.append(dict(raw))
        frames = list(self.window)
        if len(frames) == self.options.frames and steady(frames, self.options.feature_tol):
            self.result = Settled(*average(frames), frames=len(frames), settled=True)

    def check(self, now_ns: int) -> Settled | None:
        """The settled pose once it is known; raises :class:`StalledError` when the servos did
        not get there in time."""
        if self.result is not None:
            return self.result
        if self.reached_ns is None:
            if now_ns - self.commanded_ns > self.options.reach_timeout_s * 1e9:
                raise StalledError(
                    f"the servos did not reach the commanded pose within "
                    f"{self.options.reach_timeout_s:g} s"
                )
            return None
        if now_ns - self.reached_ns >= self.options.max_wait_s * 1e9 and self.window:
            frames = list(self.window)
            self.result = Settled(*average(frames), frames=len(frames), settled=False)
        return self.result
