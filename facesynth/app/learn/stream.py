"""Streaming babbling: the head moved along smooth random trajectories, learned from every frame.

After the sweeps, a babbling that waits for each pose to settle takes about one pose a second;
the camera meanwhile sees thirty faces a second that the fit never uses. Streaming keeps the
head moving instead: each servo follows a :class:`Trajectory` (a few sinusoids of random
frequency and phase, seeded), and every frame the camera takes becomes a sample, its face
paired with the commands sent one response lag earlier (:func:`lagged_commands`; the lag
measured on the sweeps' one-servo moves, :mod:`facesynth.app.learn.session_lag`, reduced to
one by :func:`stream_lag`). On simhead16 through its camera, ten minutes of it gave held-out
command errors of 0.089-0.095 of range against 0.100 from the 676 settled poses of the same
ten minutes, but no better likeness (docs/learning.md, "Learning from every frame").

Neighbouring frames are nearly the same sample, so the fit holds out whole stretches of the
stream (:func:`stream_blocks`), never single frames whose neighbours it trained on.

Pure, time as data.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = [
    "BLOCK_S",
    "DEFAULT_LAG_S",
    "HISTORY_S",
    "MAX_GAP_S",
    "MAX_LAG_S",
    "STREAM_KIND",
    "StreamFrame",
    "StreamOptions",
    "Streaming",
    "Trajectory",
    "lagged_commands",
    "stream_blocks",
    "stream_lag",
]

#: The sample kind of a streamed frame (:class:`~facesynth.schemas.messages.BabbleSample`).
STREAM_KIND = "stream"
#: The stretches of stream the fit holds out whole (s).
BLOCK_S = 2.0
#: The lag a stream is paired at when the session measured none (s): about simhead16's.
DEFAULT_LAG_S = 0.1
#: The longest lag a stream is paired at (s): simhead16_stiff's slowest skin is 0.15 s.
MAX_LAG_S = 0.25
#: Frames further apart than this (s: the face was lost, the run paused or was resumed) start a
#: new stretch, and no command is interpolated across them.
MAX_GAP_S = 0.5


class StreamError(ValueError):
    """Streaming options or data that cannot be used."""


@dataclass(frozen=True)
class StreamOptions:
    """The trajectories' shape: ``waves`` sinusoids a servo, frequencies uniform in
    ``[min_hz, max_hz]``, each of ``amplitude`` (normalized command; their sum is clipped to
    [-1, 1])."""

    max_hz: float = 1.0
    min_hz: float = 0.05
    waves: int = 4
    amplitude: float = 0.4

    def __post_init__(self) -> None:
        if not 0 < self.min_hz <= self.max_hz <= 10:
            raise StreamError(
                f"the stream's frequencies must satisfy 0 < min ({self.min_hz:g} Hz) "
                f"<= max ({self.max_hz:g} Hz) <= 10 Hz"
            )
        if not 1 <= self.waves <= 16 or not 0 < self.amplitude <= 1:
            raise StreamError("a stream needs 1-16 waves a servo, each of amplitude (0, 1]")


class Trajectory:
    """Where each of ``servos`` servos is commanded ``t_s`` seconds into the stream
    (normalized, in [-1, 1]; 0 is neutral): seeded, so a resumed run can go on with it."""

    def __init__(self, servos: int, seed: int, options: StreamOptions | None = None) -> None:
        self.options = options or StreamOptions()
        rng = np.random.default_rng([seed, 0x5EED5])
        shape = (servos, self.options.waves)
        self._hz = rng.uniform(self.options.min_hz, self.options.max_hz, shape)
        self._phase = rng.uniform(0.0, 2 * np.pi, shape)

    def at(self, t_s: float) -> np.ndarray:
        """The normalized command of every servo at ``t_s``, (servos,)."""
        waves = np.sin(2 * np.pi * self._hz * t_s + self._phase)
        out: np.ndarray = np.clip(self.options.amplitude * waves.sum(axis=1), -1.0, 1.0)
        return out


@dataclass(frozen=True)
class Streaming:
    """Stream from pose ``start`` of the plan on, along ``trajectory`` from ``offset_s`` into it
    (a resumed run goes on where the last one stopped)."""

    start: int
    trajectory: Trajectory
    offset_s: float = 0.0
    #: A settled neutral pose this often while streaming (s).
    neutral_every_s: float = 20.0


@dataclass(frozen=True)
class StreamFrame:
    """A frame taken while streaming: its face's raw features and the commands in force when
    it was taken (``t_ns``, the monotonic clock)."""

    t_ns: int
    commanded: dict[str, float]
    features: dict[str, float]


#: How long the babbler (:mod:`facesynth.app.learn.core`) remembers its commands while
#: streaming, for frames that arrive late (the tracker's latency; seconds).
HISTORY_S = 3.0


def stream_lag(lags: Mapping[str, float], servos: Sequence[str]) -> float:
    """The one lag a stream is paired at from the per-servo ``lags`` a session measured: their
    median over ``servos``, within ``[0, MAX_LAG_S]`` (:data:`DEFAULT_LAG_S` when none was
    measured). One lag, not each servo's own: a weak servo's few moves give a noisy lag (on a
    10-minute session of simhead16 the eyes' y read -0.06 and -0.03 s, the jaw 0.21 s), and
    paired at the median, each servo's own or a fixed 0.1 s the held-out error was within
    0.001 (docs/learning.md)."""
    known = [float(value) for name, value in lags.items() if name in servos]
    if not known:
        return DEFAULT_LAG_S
    return float(np.clip(np.median(known), 0.0, MAX_LAG_S))


def lagged_commands(t_ns: np.ndarray, commanded: np.ndarray, lags_s: np.ndarray) -> np.ndarray:
    """Per frame of a stream (``t_ns`` (n,) increasing capture times, ``commanded`` (n, S) the
    commands in force when each was taken), the commands sent ``lags_s`` (S,) earlier: each
    servo's linearly interpolated between the frames around ``t - lag``. NaN where that instant
    is before the stream's first frame or within a gap of more than :data:`MAX_GAP_S`."""
    t = np.asarray(t_ns, dtype=np.float64) / 1e9
    commanded = np.asarray(commanded, dtype=np.float64)
    if commanded.shape != (len(t), len(lags_s)):
        raise StreamError(f"commands {commanded.shape} do not match {len(t)} frames")
    if len(t) > 1 and np.any(np.diff(t) < 0):
        raise StreamError("the stream's frames are not in time order")
    if not np.all(np.asarray(lags_s, dtype=np.float64) >= 0):
        raise StreamError("a response lag is a time the face follows after, not negative")
    out = np.full(commanded.shape, np.nan)
    if not len(t):
        return out
    for servo, lag in enumerate(np.asarray(lags_s, dtype=np.float64)):
        wanted = t - lag
        after = np.minimum(np.searchsorted(t, wanted, side="right"), len(t) - 1)
        before = np.maximum(after - 1, 0)
        within = (t[after] - t[before] <= MAX_GAP_S) | (wanted >= t[-1]) | (wanted == t[before])
        usable = (wanted >= t[0]) & within
        value = np.interp(wanted, t, commanded[:, servo])
        out[:, servo] = np.where(usable, value, np.nan)
    return out


def stream_blocks(t_ns: np.ndarray, block_s: float = BLOCK_S) -> np.ndarray:
    """Per frame (``t_ns`` increasing), the stretch of the stream it is in: ``block_s`` long,
    a new one after every gap of more than :data:`MAX_GAP_S`; (n,) ints from 0."""
    if not block_s > 0:
        raise StreamError(f"a stretch of stream lasts some time, not {block_s:g} s")
    t = np.asarray(t_ns, dtype=np.float64) / 1e9
    if not len(t):
        return np.zeros(0, dtype=np.int64)
    runs = np.concatenate([[0], np.cumsum(np.diff(t) > MAX_GAP_S)])
    blocks = np.zeros(len(t), dtype=np.int64)
    next_block = 0
    for run in np.unique(runs):
        rows = runs == run
        local = np.floor((t[rows] - t[rows][0]) / block_s).astype(np.int64)
        blocks[rows] = next_block + local
        next_block += int(local.max()) + 1
    return blocks
