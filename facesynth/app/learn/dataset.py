"""The babbling data set: every settled pose's commands and the face the camera saw.

The seam between the babbling session (which reads a recorded session into a
:class:`BabbleSet`) and the fitting (:mod:`facesynth.app.learn.fit`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from facesynth.app.learn.stream import (
    DEFAULT_LAG_S,
    STREAM_KIND,
    lagged_commands,
    stream_blocks,
    stream_lag,
)
from facesynth.runtime.profiles import Profile

#: What a sample is: the neutral pose re-checked, a single-channel sweep step, a random pose,
#: a frame of a streamed babbling (:mod:`facesynth.app.learn.stream`).
KINDS = ("neutral", "sweep", "random", "stream")


@dataclass(frozen=True)
class BabbleSet:
    """Babbling samples, one row each: settled poses, and frames of a stream.

    Attributes:
        servos: the profile's servo names, in column order of ``commands``.
        commands: (N, S) pulses in µs, as commanded (and reached) for each pose.
        inputs: feature names, in column order of ``faces``.
        faces: (N, F) ``Features.raw`` values of the settled face (NaN where absent).
        kinds: per sample, one of :data:`KINDS`.
        lags: per servo, the head's response lag (s) where the babbling measured it
            (:mod:`facesynth.app.learn.lag`, the fit reports it; empty: not measured).
        blocks: per sample, the stretch of stream it is in (:func:`~facesynth.app.learn.stream.
            stream_blocks`; the fit holds stretches out whole), -1 for a settled pose; ``None``:
            no stream.
    """

    servos: tuple[str, ...]
    commands: np.ndarray
    inputs: tuple[str, ...]
    faces: np.ndarray
    kinds: tuple[str, ...]
    lags: Mapping[str, float] = field(default_factory=dict)
    blocks: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = len(self.kinds)
        if self.blocks is not None and np.shape(self.blocks) != (n,):
            raise ValueError(f"blocks shape {np.shape(self.blocks)} is not ({n},)")
        if self.commands.shape != (n, len(self.servos)):
            raise ValueError(
                f"commands shape {self.commands.shape} is not ({n}, {len(self.servos)})"
            )
        if self.faces.shape != (n, len(self.inputs)):
            raise ValueError(f"faces shape {self.faces.shape} is not ({n}, {len(self.inputs)})")
        unknown = sorted(set(self.kinds) - set(KINDS))
        if unknown:
            raise ValueError(f"unknown sample kinds {unknown}; known: {', '.join(KINDS)}")

    def __len__(self) -> int:
        return len(self.kinds)

    def normalized(self, profile: Profile) -> np.ndarray:
        """(N, S) commands in [-1, 1]: 0 at each servo's neutral, +1 at max_us, -1 at min_us."""
        specs = [profile.servo(name) for name in self.servos]
        neutral = np.array([s.neutral_us for s in specs])
        up = np.array([s.max_us - s.neutral_us for s in specs])
        down = np.array([s.neutral_us - s.min_us for s in specs])
        delta = self.commands - neutral
        scale = np.where(delta >= 0, np.where(up > 0, up, 1.0), np.where(down > 0, down, 1.0))
        out: np.ndarray = np.clip(delta / scale, -1.0, 1.0)
        return out

    def stretches(self) -> np.ndarray:
        """(N,) the stretch of stream of each sample, -1 for a settled pose."""
        if self.blocks is None:
            return np.full(len(self), -1, dtype=np.int64)
        return np.asarray(self.blocks, dtype=np.int64)

    def with_stream(
        self,
        t_ns: np.ndarray,
        commanded: np.ndarray,
        faces: np.ndarray,
        lag_s: float | Mapping[str, float] = DEFAULT_LAG_S,
    ) -> BabbleSet:
        """These samples and a stream's frames (``t_ns`` (n,) capture times in order,
        ``commanded`` (n, S) the pulses in force at each, ``faces`` (n, F) over ``inputs``),
        each face paired with the commands sent the head's lag earlier (``lag_s``; given per
        servo, as a session's one-servo moves measure it, the median over the servos within
        ``[0, MAX_LAG_S]``, for every servo: :func:`~facesynth.app.learn.stream.stream_lag`;
        :func:`~facesynth.app.learn.stream.lagged_commands`); frames with no such command are
        left out."""
        lag = stream_lag(lag_s, self.servos) if isinstance(lag_s, Mapping) else float(lag_s)
        lags = np.full(len(self.servos), lag)
        paired = lagged_commands(t_ns, commanded, lags)
        keep = np.all(np.isfinite(paired), axis=1)
        faces = np.asarray(faces, dtype=np.float64)
        if faces.shape != (len(keep), len(self.inputs)):
            raise ValueError(f"stream faces {faces.shape} do not match ({len(keep)}, inputs)")
        stretches = self.stretches()
        first = int(stretches.max()) + 1 if len(stretches) else 0
        blocks = first + stream_blocks(np.asarray(t_ns)[keep])
        return BabbleSet(
            self.servos,
            np.vstack([self.commands, paired[keep]]),
            self.inputs,
            np.vstack([self.faces, faces[keep]]),
            self.kinds + (STREAM_KIND,) * int(keep.sum()),
            self.lags,
            np.concatenate([stretches, blocks]),
        )
