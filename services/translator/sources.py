"""Translator T's sources, one servo at a time (steps 1-4 of
:mod:`facesynth.services.translator.core`).

A :class:`ServoWiring` holds what a servo reads (a point group, named features or a mix of
them), the face range its point group maps from, and its motion state (rate limiter, ramp).
:meth:`ServoWiring.target` turns one frame's sources into the servo's target position:
each signal through its One Euro filter (shared with every servo reading it with the same
parameters), then the dead-band, the gain, one side, and the mapping onto the servo's range.
A frame's point groups are averaged all at once first (:class:`GroupMeans`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping

import numpy as np

from facesynth.runtime.calibration import Calibration
from facesynth.runtime.landmarks import MIRROR
from facesynth.runtime.profiles import ServoSpec, Smoothing
from facesynth.services.translator.filters import OneEuroFilter, RateLimiter
from facesynth.services.translator.mapping import deadband, interpolate, scaled_position

#: One filter per distinct signal (a point group or a named feature, with its parameters).
Filters = dict[tuple[object, ...], OneEuroFilter | None]
#: A point group (its iBUG indices) and, per frame, its mean delta.
Group = tuple[int, ...]
Means = Mapping[Group, float]


class GroupMeans:
    """Every point group's mean delta of a frame at once, bit for bit ``deltas[group].mean()``:
    the groups of one size are stacked into one index, so a frame takes one gather and one
    row-wise sum per size, divided by the size (a 2-D reduction sums each row as the 1-D one
    sums its group; the division is the mean's own) instead of a gather and a mean per group
    (paper16: 13 groups of 4 sizes)."""

    def __init__(self, groups: Iterable[Group]) -> None:
        by_size: dict[int, list[Group]] = {}
        for group in dict.fromkeys(groups):  # each once, in order
            if group:
                by_size.setdefault(len(group), []).append(group)
        self._batches = [
            (np.array(members, dtype=np.intp), members) for members in by_size.values()
        ]

    def __call__(self, deltas: np.ndarray) -> dict[Group, float]:
        """Each group's mean of ``deltas`` (one frame's, shape (68,))."""
        out: dict[Group, float] = {}
        for index, members in self._batches:
            # the sum, then / the count: what ndarray.mean does, without its Python layer
            means = np.add.reduce(deltas[index], axis=1) / index.shape[1]
            out.update(zip(members, means.tolist(), strict=True))
        return out


def smoothing_filter(params: Smoothing | None) -> OneEuroFilter | None:
    """A One Euro filter with ``params`` (None: the signal is not smoothed)."""
    if params is None:
        return None
    return OneEuroFilter(params.min_cutoff, params.beta, params.d_cutoff)


def _params(params: Smoothing | None) -> tuple[float, float, float] | None:
    return None if params is None else (params.min_cutoff, params.beta, params.d_cutoff)


def face_range(
    spec: ServoSpec, calibration: Calibration | None, mirror: bool
) -> tuple[float, float]:
    """The face range a servo's point group maps from: the profile's, or the calibration's
    where the group moved during calibration; (-1, 1) for named features (F scales them)."""
    if not spec.points or spec.face_min is None or spec.face_max is None:
        return (-1.0, 1.0)  # named features are scaled by F
    if calibration is None:
        return (spec.face_min, spec.face_max)
    group = np.asarray(spec.points, dtype=np.intp)
    source = MIRROR[group] if mirror else group
    low = float(np.mean(np.asarray(calibration.delta_min)[source]))
    high = float(np.mean(np.asarray(calibration.delta_max)[source]))
    # A point group that did not move during calibration keeps the profile default.
    return (low if low < 0 else spec.face_min, high if high > 0 else spec.face_max)


def _feature_value(
    key: tuple[object, ...],
    value: float,
    t_ns: int | None,
    filters: Filters,
    cache: dict[object, float],
) -> float:
    if key not in cache:
        flt = filters.get(key)
        cache[key] = flt(value, t_ns) if flt is not None and t_ns is not None else value
    return cache[key]


class ServoWiring:
    """Per-servo wiring: source, range, filters, limiter."""

    def __init__(self, spec: ServoSpec, face_range: tuple[float, float], params: Smoothing | None):
        self.spec = spec
        self.group = np.asarray(spec.points, dtype=np.intp)
        self.points: Group = tuple(spec.points)
        self.range = face_range
        self.weights = spec.weights()
        key = _params(params)
        # Signals shared by several servos with the same parameters share one filter.
        self.group_key = ("points", self.points, face_range, key)
        self.feature_keys = {name: ("feature", name, key) for name in self.weights or {}}
        self.params = params
        self.limiter = RateLimiter(spec.max_speed, spec.max_accel)
        self.seen = False  # the named features were in a frame since reset()
        self.ramp: float | None = None  # speed of a ramp after a tracking change (µs/s)

    @property
    def unlimited(self) -> bool:
        return self.spec.max_speed <= 0 and self.spec.max_accel <= 0 and self.ramp is None

    def add_filters(self, filters: Filters) -> None:
        """Add a filter to ``filters`` for each signal this servo reads."""
        if len(self.group):
            filters[self.group_key] = smoothing_filter(self.params)
        for key in self.feature_keys.values():
            filters[key] = smoothing_filter(self.params)

    def _group_value(
        self, means: Means, t_ns: int | None, filters: Filters, cache: dict[object, float]
    ) -> float:
        key = self.group_key
        if key not in cache:
            movement = means[self.points]
            flt = filters.get(key)
            if flt is not None and t_ns is not None:
                low, high = self.range
                half = (high - low) / 2.0
                movement = flt(movement / half, t_ns) * half
            cache[key] = movement
        return cache[key]

    def target(
        self,
        means: Means | None,
        named: Mapping[str, float],
        t_ns: int | None,
        filters: Filters,
        cache: dict[object, float],
    ) -> float | None:
        """The servo's target position (None: its source is missing from this frame);
        ``means``: the frame's point groups' mean deltas (:class:`GroupMeans`; None: no deltas).

        Sources are filtered when ``t_ns`` is given; ``cache`` holds each signal's value for
        this frame, so a signal shared by several servos is computed (and filtered) once.
        """
        spec = self.spec
        if self.weights is not None:
            if all(math.isfinite(named.get(name, math.nan)) for name in self.weights):
                self.seen = True
                value = sum(
                    weight
                    * _feature_value(self.feature_keys[name], named[name], t_ns, filters, cache)
                    for name, weight in self.weights.items()
                )
                value = deadband(value, spec.deadband) * spec.gain
                return scaled_position(max(value, 0.0) if spec.one_sided else value, spec)
            if self.seen or not spec.points:
                return None  # hold; points are only a fallback while the features never came
        if means is None:
            return None
        low, high = self.range
        width = spec.deadband
        if self.weights is not None:  # a fallback: the dead-band is in scaled units
            width *= (high - low) / 2.0
        movement = deadband(self._group_value(means, t_ns, filters, cache), width) * spec.gain
        return interpolate(max(movement, 0.0) if spec.one_sided else movement, low, high, spec)
