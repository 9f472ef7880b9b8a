"""When a babbling pose has settled: the servos got there, then the face held still.

Pure, time as data (monotonic ns). After a pose is commanded, :class:`Settle` waits until
``…/servo_state`` reports every servo within ``reach_tol_us`` of its command, then at least
``min_wait_s`` more (the servo travels, the skin lags it), then collects the face's raw
features frame by frame: the pose has settled when the last ``frames`` frames agree (the
``STEADY_QUANTILE`` of their per-feature spans is within ``feature_tol``), or, ``max_wait_s``
after the servos got there, with whatever the last frames were (``settled`` false). Servos
that do not get there within ``reach_timeout_s`` raise :class:`StalledError`.

When the driver reads the servos back (``measured`` on ``…/servo_state``, for every servo of
the pose), the servos get there when their *measured* positions are within
``measured_tol_us`` of the command, and no fixed ``min_wait_s`` is waited; a servo that does
not get there (held by the skin, stalled) is given ``measured_timeout_s`` after C reported the
command, then the pose is taken anyway. :attr:`Settled.reached` says which it was.
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
    measured_tol_us: float = 20.0
    measured_timeout_s: float = 3.0

    def __post_init__(self) -> None:
        if self.frames < 1:
            raise SettleError("a pose settles over at least one frame")
        if not (self.reach_tol_us > 0 and self.feature_tol > 0 and self.measured_tol_us > 0):
            raise SettleError("the settle tolerances must be positive")
        if not self.measured_timeout_s > 0:
            raise SettleError("the measured-position timeout must be positive")
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
    #: How the servos were known to be there: ``"commanded"`` (C reported the command; then
    #: the fixed wait), ``"measured"`` (read back within the tolerance) or ``"measured
    #: timeout"`` (read back, but not within the tolerance in time).
    reached: str = "commanded"


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


def near(positions: Mapping[str, float], goal: Mapping[str, float], tolerance: float) -> bool:
    """Whether every servo of ``goal`` is reported within ``tolerance`` of it (µs)."""
    return all(abs(positions.get(name, -1e9) - value) <= tolerance for name, value in goal.items())


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
        self.reached = "commanded"
        #: When C reported the command (the measured timeout runs from there).
        self.reported_ns: int | None = None
        #: Whether the servos of the pose are read back (the driver reports ``measured``).
        self.reading = False
        self.window: collections.deque[dict[str, float]] = collections.deque(maxlen=options.frames)
        self.result: Settled | None = None

    def servos(
        self,
        positions: Mapping[str, float],
        now_ns: int,
        measured: Mapping[str, float] | None = None,
    ) -> None:
        """Where the control interface reports the servos: commanded, and ``measured`` where
        the driver reads them back."""
        if self.reached_ns is not None:
            return
        if self.reported_ns is None and near(positions, self.target, self.options.reach_tol_us):
            self.reported_ns = now_ns
        if measured and set(self.target) <= set(measured):
            self.reading = True
        if not self.reading:
            self.reached_ns = self.reported_ns
        elif (
            self.reported_ns is not None
            and measured
            and near(measured, self.target, self.options.measured_tol_us)
        ):
            self.reached_ns, self.reached = now_ns, "measured"

    def face(self, raw: Mapping[str, float], now_ns: int) -> None:
        """One frame's raw features (a frame with a face)."""
        if self.result is not None or self.reached_ns is None:
            return
        wait = 0.0 if self.reading else self.options.min_wait_s
        if now_ns - self.reached_ns < wait * 1e9:
            return
        self.window.append(dict(raw))
        frames = list(self.window)
        if len(frames) == self.options.frames and steady(frames, self.options.feature_tol):
            self.result = Settled(
                *average(frames), frames=len(frames), settled=True, reached=self.reached
            )

    def check(self, now_ns: int) -> Settled | None:
        """The settled pose once it is known; raises :class:`StalledError` when the servos did
        not get there in time."""
        if self.result is not None:
            return self.result
        reported = self.reported_ns
        if (
            self.reached_ns is None
            and self.reading
            and reported is not None
            and now_ns - reported >= self.options.measured_timeout_s * 1e9
        ):
            self.reached_ns, self.reached = now_ns, "measured timeout"
        if self.reached_ns is None:
            if now_ns - self.commanded_ns > self.options.reach_timeout_s * 1e9:
                raise StalledError(
                    f"the servos did not reach the commanded pose within "
                    f"{self.options.reach_timeout_s:g} s"
                )
            return None
        if now_ns - self.reached_ns >= self.options.max_wait_s * 1e9 and self.window:
            frames = list(self.window)
            self.result = Settled(
                *average(frames), frames=len(frames), settled=False, reached=self.reached
            )
        return self.result
