"""Resident memory over a soak, pure: samples in, steps and slopes out.

A process's RSS is sampled every few seconds; each *incarnation* (one pid: a process killed
and started again is a new incarnation) is a series of :class:`Sample`. Two kinds of growth are
told apart, because they mean different things:

- a **step**: RSS rising by at least ``step_mb`` between two samples, as when a buffer grows
  once to hold a large message (Zenoh's reassembly buffers are kept for reuse) — consecutive
  rising samples are one step;
- a **slope**: the steady growth left after the last step, by a least-squares line through the
  samples after it (MB per hour), as a leak would show.

The first ``warmup_s`` seconds of an incarnation (imports, the model, caches filling) are
neither. Times are seconds since the soak began.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass, field

#: A rise of at least this much between two samples is a step (MB).
STEP_MB = 2.0
#: An incarnation's first seconds are its warm-up: no steps, no slope.
WARMUP_S = 60.0
#: A slope is fitted only over at least this long (seconds) and this many samples.
MIN_FIT_S = 120.0
MIN_FIT_SAMPLES = 5


@dataclass(frozen=True)
class Sample:
    """One reading: ``t_s`` seconds since the soak began, ``mb`` resident megabytes."""

    t_s: float
    mb: float


@dataclass(frozen=True)
class Step:
    """RSS rising from ``before_mb`` to ``after_mb`` between ``start_s`` and ``end_s``."""

    start_s: float
    end_s: float
    before_mb: float
    after_mb: float

    @property
    def rise_mb(self) -> float:
        return self.after_mb - self.before_mb


@dataclass(frozen=True)
class Slope:
    """A least-squares fit: ``mb_per_hour`` over ``span_s`` seconds from ``start_s``."""

    mb_per_hour: float
    start_s: float
    span_s: float
    samples: int


@dataclass
class Incarnation:
    """One pid of one process and its samples, in time order."""

    process: str
    pid: int
    samples: list[Sample] = field(default_factory=list)


def steps(samples: Sequence[Sample], step_mb: float = STEP_MB) -> list[Step]:
    """The steps of a series (after nothing but its own order: pass it without the warm-up)."""
    found: list[Step] = []
    for before, after in itertools.pairwise(samples):
        if after.mb - before.mb < step_mb:
            continue
        if found and found[-1].end_s == before.t_s:  # still rising: the same step
            last = found[-1]
            found[-1] = Step(last.start_s, after.t_s, last.before_mb, after.mb)
        else:
            found.append(Step(before.t_s, after.t_s, before.mb, after.mb))
    return found


def slope(samples: Sequence[Sample]) -> Slope | None:
    """The least-squares slope of a series (MB/hour); ``None`` when it is too short to say."""
    if len(samples) < MIN_FIT_SAMPLES or samples[-1].t_s - samples[0].t_s < MIN_FIT_S:
        return None
    n = len(samples)
    mean_t = sum(s.t_s for s in samples) / n
    mean_mb = sum(s.mb for s in samples) / n
    var = sum((s.t_s - mean_t) ** 2 for s in samples)
    cov = sum((s.t_s - mean_t) * (s.mb - mean_mb) for s in samples)
    return Slope(
        mb_per_hour=cov / var * 3600.0,
        start_s=samples[0].t_s,
        span_s=samples[-1].t_s - samples[0].t_s,
        samples=n,
    )


@dataclass(frozen=True)
class IncarnationFigures:
    """What one incarnation showed."""

    pid: int
    start_s: float
    end_s: float
    first_mb: float
    last_mb: float
    peak_mb: float
    steps: list[Step]
    #: The slope after the last step (and the warm-up); ``None`` when too short to fit.
    slope: Slope | None


def incarnation_figures(
    incarnation: Incarnation, warmup_s: float = WARMUP_S, step_mb: float = STEP_MB
) -> IncarnationFigures | None:
    """Steps and the slope after the last of them; ``None`` for an incarnation without
    samples."""
    series = incarnation.samples
    if not series:
        return None
    settled = [s for s in series if s.t_s - series[0].t_s >= warmup_s]
    found = steps(settled, step_mb)
    after = [s for s in settled if not found or s.t_s >= found[-1].end_s]
    return IncarnationFigures(
        pid=incarnation.pid,
        start_s=series[0].t_s,
        end_s=series[-1].t_s,
        first_mb=series[0].mb,
        last_mb=series[-1].mb,
        peak_mb=max(s.mb for s in series),
        steps=found,
        slope=slope(after),
    )


@dataclass(frozen=True)
class Hour:
    """One hour of a process's samples (every incarnation): the hour's index from the soak's
    start, its first, last and largest reading."""

    hour: int
    first_mb: float
    last_mb: float
    peak_mb: float


def hours(incarnations: Sequence[Incarnation]) -> list[Hour]:
    """A process's RSS per hour of the soak (the last hour may be partial)."""
    merged = sorted((s for inc in incarnations for s in inc.samples), key=lambda s: s.t_s)
    by_hour: dict[int, list[Sample]] = {}
    for sample in merged:
        by_hour.setdefault(int(sample.t_s // 3600), []).append(sample)
    return [
        Hour(hour, group[0].mb, group[-1].mb, max(s.mb for s in group))
        for hour, group in sorted(by_hour.items())
    ]


@dataclass(frozen=True)
class ProcessFigures:
    """A process over the whole soak."""

    process: str
    incarnations: list[IncarnationFigures]
    hours: list[Hour]

    @property
    def steps(self) -> list[Step]:
        return [step for inc in self.incarnations for step in inc.steps]

    @property
    def slope(self) -> Slope | None:
        """The slope fitted over the longest span of any incarnation (the most telling)."""
        fitted = [inc.slope for inc in self.incarnations if inc.slope is not None]
        return max(fitted, key=lambda s: s.span_s, default=None)


def process_figures(
    process: str,
    incarnations: Sequence[Incarnation],
    warmup_s: float = WARMUP_S,
    step_mb: float = STEP_MB,
) -> ProcessFigures:
    """Every incarnation of ``process`` summed up."""
    figures = [incarnation_figures(inc, warmup_s, step_mb) for inc in incarnations]
    return ProcessFigures(
        process=process,
        incarnations=[f for f in figures if f is not None],
        hours=hours(incarnations),
    )
