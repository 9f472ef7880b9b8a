"""Automatic neutral and ranges from the running stream, for performers who skip calibration.

Both use media time (``t_media_ns``) only, never the wall clock, so a replay gives the same
values every time.

* :class:`RollingNeutral`: the neutral is the per-value median of samples taken every
  ``sample_s`` over the last ``window_s`` (10 s), recomputed every ``update_s`` (0.5 s). The
  window starts full of the initial neutral (the first second's median, or a calibration's), so
  the neutral moves only once a new face has been held for more than half the window (5 s): an
  expression held for a couple of seconds never becomes the neutral, a new resting face does.
  Missing values (NaN) are ignored; when media time goes backwards (a looping replay) the
  samples are kept and timing restarts.
* :class:`AutoRange`: per named feature, the range [min, max] (relative to the neutral) starts
  at the calibrated or default range. A value beyond it widens it at once (the median of the
  last 3 frames, so a one-frame tracking glitch does not; frames before a gap of more than 1 s
  do not count). Between widenings each end decays exponentially (time constant ``tau_s``,
  30 s) toward ``floor_fraction`` (0.5) of the initial range and never closer to 0, so noise on
  a feature the performer does not use is not amplified beyond twice the initial gain. The
  rolling neutral of the named features covers head pose and gaze too: a head turn or gaze
  held for more than 5 s becomes the new centre.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np


def nan_median(samples: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """Per-column median of (n, d) samples ignoring NaN; ``fallback`` where a column is all NaN.

    (``np.nanmedian`` gives the same but is several times slower on small arrays.)
    """
    ordered = np.sort(samples, axis=0)  # NaN sort last
    count = (~np.isnan(samples)).sum(axis=0)
    columns = np.arange(samples.shape[1])
    low = ordered[np.maximum(count - 1, 0) // 2, columns]
    high = ordered[count // 2 - (count == 0), columns]  # no NaN index when count is 0
    median: np.ndarray = np.where(count > 0, (low + high) / 2.0, fallback)
    return median


class RollingNeutral:
    """The median of a vector over a trailing window of media time (see the module doc)."""

    def __init__(
        self,
        initial: np.ndarray,
        *,
        window_s: float = 10.0,
        sample_s: float = 0.1,
        update_s: float = 0.5,
    ) -> None:
        if not (window_s > 0 and sample_s > 0 and update_s > 0 and sample_s <= window_s):
            raise ValueError("rolling neutral needs window_s >= sample_s > 0 and update_s > 0")
        size = max(1, round(window_s / sample_s))
        self.neutral = np.array(initial, dtype=np.float64)
        self._buffer = np.tile(self.neutral, (size, 1))
        self._next = 0
        self._sample_ns = round(sample_s * 1e9)
        self._update_ns = round(update_s * 1e9)
        self._last_sample: int | None = None
        self._last_update: int | None = None

    def add(self, t_ns: int, values: np.ndarray) -> np.ndarray:
        """Offer one frame's values (NaN: missing); return the current neutral."""
        last = self._last_sample
        if last is None or t_ns - last >= self._sample_ns or t_ns < last:
            self._buffer[self._next] = values
            self._next = (self._next + 1) % len(self._buffer)
            self._last_sample = t_ns
        if self._last_update is None:
            self._last_update = t_ns
        elif t_ns - self._last_update >= self._update_ns or t_ns < self._last_update:
            self._last_update = t_ns
            self.neutral = nan_median(self._buffer, self.neutral)
        return self.neutral


#: After a gap in the stream longer than this, earlier frames no longer widen a range.
GAP_NS = 1_000_000_000


class AutoRange:
    """Per-feature ranges that widen with the stream and decay slowly (see the module doc)."""

    def __init__(
        self,
        names: Sequence[str],
        ranges: Mapping[str, tuple[float, float]],
        *,
        tau_s: float = 30.0,
        floor_fraction: float = 0.5,
        glitch_frames: int = 3,
    ) -> None:
        if not (tau_s > 0 and 0 < floor_fraction <= 1 and glitch_frames >= 1):
            raise ValueError("auto range needs tau_s > 0, 0 < floor_fraction <= 1, frames >= 1")
        self.names = tuple(names)
        self._index = {name: i for i, name in enumerate(self.names)}
        initial = np.array([ranges[name] for name in self.names], dtype=np.float64)
        self.lo, self.hi = initial[:, 0].copy(), initial[:, 1].copy()
        self.floor_lo, self.floor_hi = floor_fraction * self.lo, floor_fraction * self.hi
        self._tau_ns = tau_s * 1e9
        self._recent = np.full((glitch_frames, len(self.names)), np.nan)
        self._next = 0
        self._last_t: int | None = None

    def update(self, t_ns: int, rel: Mapping[str, float]) -> dict[str, tuple[float, float]]:
        """Take one frame's relative values; return the ranges to scale them with."""
        if self._last_t is not None and t_ns > self._last_t:
            keep = math.exp(-(t_ns - self._last_t) / self._tau_ns)
            self.hi = self.floor_hi + (self.hi - self.floor_hi) * keep
            self.lo = self.floor_lo + (self.lo - self.floor_lo) * keep
            if t_ns - self._last_t > GAP_NS:
                self._recent[:] = np.nan  # frames from before a gap are not "recent"
        self._last_t = t_ns
        row = np.full(len(self.names), np.nan)
        for name, value in rel.items():
            i = self._index.get(name)
            if i is not None:
                row[i] = value
        self._recent[self._next] = row
        self._next = (self._next + 1) % len(self._recent)
        # the median of the recent frames; NaN where one of them lacks the feature
        candidate = np.sort(self._recent, axis=0)[len(self._recent) // 2]
        if len(self._recent) % 2 == 0:
            candidate = (candidate + np.sort(self._recent, axis=0)[len(self._recent) // 2 - 1]) / 2
        candidate[np.isnan(self._recent).any(axis=0)] = np.nan
        self.hi = np.fmax(self.hi, candidate)
        self.lo = np.fmin(self.lo, candidate)
        return self.ranges()

    def ranges(self) -> dict[str, tuple[float, float]]:
        """The current range of every feature."""
        return {
            name: (float(lo), float(hi))
            for name, lo, hi in zip(self.names, self.lo, self.hi, strict=True)
        }
