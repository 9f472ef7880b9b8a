"""How much the robot's face moves like the performer's: the pure core of ``bench robot``.

Two streams of named features (``Features.raw``: relative to each face's own neutral, unscaled,
so both sides are in the same units), aligned per frame: the performer's, and the robot's as
its camera sees it through the same tracker and F. Per feature:

* **moved**: the performer's span (p95 − p5 over the frames with a value) is at least
  :data:`MOVED_SPAN` of the feature's unit: 3 degrees of head pose, 0.04 eye widths of gaze,
  0.05 of the lid gap over the eye width, 0.02 inter-ocular distances, 0.1 of a blendshape
  score. Only moved features are compared;
* **ρ**: Pearson's correlation over the frames where both sides have a value (0 when either
  side is constant there: a head that never moves a feature does not follow it);
* **ratio**: the robot's span over the performer's (same percentiles, same frames);
* **ratio in reach** (:func:`reach_ratio`, when the robot's reach is known: a learned
  profile's ``reach_low`` .. ``reach_high``): the robot's span over the span of her change
  *clipped into the robot's reach* (gain 1, same frames), so amplitude she shows where the
  robot cannot go does not count as lost; NaN when her clipped change does not move;
* **reach**: across every profile measured on one head, a feature the robot never moves by
  :data:`REACH_RATIO` of the performer's span and by :data:`REACH_FLOOR` of its unit's
  threshold is one the head cannot reach (:func:`mark_reach`): nothing any profile did moved it
  beyond a tenth of the performer's amplitude or beyond the tracker's jitter (a head that
  cannot turn still reads a degree or so of head pose as its skin moves).

Frames are compared as they are aligned (the robot's frame ``i`` is its face after the
performer's frame ``i``); :func:`best_lag` says how many frames later the robot's face matches
best (T's smoothing, C's speed limits and the actuators' slew and lag delay it).

What ``bench robot`` leads with (:func:`lead`): mean ρ and the median ratio over the features
the performer moves *and* the robot moved while babbling (a learned profile's record of its
babbling); every moved feature follows in the summary.

A profile's summary (:func:`summarize`): mean ρ over the moved features the head can reach
(and over all moved features), the median ratio over those it can reach, and the share of them
whose ratio is within :data:`RATIO_BAND`.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Final

import numpy as np

from facesynth.runtime.feature_names import BY_NAME

__all__ = [
    "MAX_LAG",
    "MOVED_SPAN",
    "RATIO_BAND",
    "REACH_FLOOR",
    "REACH_RATIO",
    "FeatureRow",
    "FeatureStream",
    "Lead",
    "Summary",
    "best_lag",
    "compare",
    "lead",
    "mark_reach",
    "moved_threshold",
    "reach_ratio",
    "span",
    "summarize",
]

#: The least performer span (p95 − p5) that counts as moving, per feature unit.
MOVED_SPAN: Final[dict[str, float]] = {
    "degrees": 3.0,
    "eye widths": 0.04,
    "lid gap / eye width": 0.05,
    "inter-ocular distance": 0.02,
    "score (0..1)": 0.1,
}
#: Below this ratio under every profile, the head cannot reach a feature ...
REACH_RATIO: Final = 0.1
#: ... nor below this share of the unit's :data:`MOVED_SPAN` (the tracker's jitter).
REACH_FLOOR: Final = 0.5
#: :func:`best_lag` looks this many frames late at most.
MAX_LAG: Final = 12
#: Amplitude ratios that count as the performer's amplitude.
RATIO_BAND: Final = (0.8, 1.25)
#: The span's percentiles (robust to a few tracking outliers).
LOW_PERCENTILE: Final = 5.0
HIGH_PERCENTILE: Final = 95.0
#: Fewer common frames than this and a feature is not compared.
MIN_FRAMES: Final = 10


def moved_threshold(name: str) -> float:
    """The least span of feature ``name`` that counts as moving (its unit's threshold)."""
    feature = BY_NAME.get(name)
    if feature is None:
        raise ValueError(f"unknown feature {name!r}")
    return MOVED_SPAN[feature.unit]


@dataclass(frozen=True)
class FeatureStream:
    """Named feature values per frame: ``values[i, j]`` is feature ``names[j]`` in frame ``i``
    (NaN where the frame has no value: no face, neutral not known yet, eye closed)."""

    names: tuple[str, ...]
    values: np.ndarray

    def __post_init__(self) -> None:
        if self.values.ndim != 2 or self.values.shape[1] != len(self.names):
            raise ValueError(
                f"values of shape {self.values.shape} for {len(self.names)} feature names"
            )
        if len(set(self.names)) != len(self.names):
            raise ValueError("feature names repeat")

    @classmethod
    def from_frames(
        cls, frames: Sequence[Mapping[str, float] | None], names: Sequence[str] | None = None
    ) -> FeatureStream:
        """A stream from each frame's ``Features.raw`` (``None`` or ``{}``: no values).

        ``names`` fixes the columns (default: every name any frame has, sorted)."""
        if names is None:
            names = sorted({name for frame in frames if frame for name in frame})
        values = np.full((len(frames), len(names)), np.nan)
        column = {name: j for j, name in enumerate(names)}
        for i, frame in enumerate(frames):
            for name, value in (frame or {}).items():
                j = column.get(name)
                if j is not None and math.isfinite(value):
                    values[i, j] = value
        return cls(tuple(names), values)

    def column(self, name: str) -> np.ndarray:
        """One feature's values per frame (all NaN when the stream lacks it)."""
        if name not in self.names:
            return np.full(len(self.values), np.nan)
        return self.values[:, self.names.index(name)]

    def __len__(self) -> int:
        return len(self.values)


def span(values: np.ndarray) -> float:
    """The robust amplitude of ``values``: p95 − p5 of the finite ones (NaN when none)."""
    finite = values[np.isfinite(values)]
    if finite.size == 0:
        return math.nan
    low, high = np.percentile(finite, [LOW_PERCENTILE, HIGH_PERCENTILE])
    return float(high - low)


def reach_ratio(theirs: np.ndarray, ours: np.ndarray, low: float, high: float) -> float:
    """The robot's span (``ours``) over the span of the performer's change (``theirs``)
    clipped into the robot's reach ``[low, high]`` (gain 1), over the frames where both have a
    value: her amplitude where the robot's reach allows it. NaN when she does not move within
    the reach (her clipped change has no span) or no frame has both."""
    both = np.isfinite(theirs) & np.isfinite(ours)
    if not both.any():
        return math.nan
    wanted = span(np.clip(theirs[both], low, high))
    return span(ours[both]) / wanted if wanted > 0 else math.nan


def _pearson(a: np.ndarray, b: np.ndarray) -> float:
    da, db = a - a.mean(), b - b.mean()
    denominator = math.sqrt(float(np.dot(da, da)) * float(np.dot(db, db)))
    if denominator <= 1e-15:
        return 0.0
    return max(-1.0, min(1.0, float(np.dot(da, db)) / denominator))


@dataclass(frozen=True)
class FeatureRow:
    """One feature of one run: the performer's span, the robot's, ρ and their ratio over the
    frames both sides have (``frames``); ``reachable`` as :func:`mark_reach` decides;
    ``reach_ratio`` as :func:`reach_ratio` gives it (NaN: the robot's reach not known)."""

    name: str
    unit: str
    frames: int
    performer_span: float
    robot_span: float
    rho: float
    ratio: float
    moved: bool
    reachable: bool = True
    reach_ratio: float = math.nan

    @property
    def in_band(self) -> bool:
        """Whether the ratio is within :data:`RATIO_BAND`."""
        return RATIO_BAND[0] <= self.ratio <= RATIO_BAND[1]


def compare(
    performer: FeatureStream,
    robot: FeatureStream,
    lag: int = 0,
    reach: Mapping[str, tuple[float, float]] | None = None,
) -> list[FeatureRow]:
    """Per performer feature (known to the contract), aligned frame by frame with the robot's.

    The streams must have the same number of frames (frame ``i`` of the robot is its face after
    the performer's frame ``i`` drove it); with ``lag``, the performer's frame ``i`` is compared
    with the robot's frame ``i + lag``. ``reach``: the robot's ``(low, high)`` per feature,
    relative to its neutral, for each row's ``reach_ratio`` (a feature without one: NaN)."""
    if len(performer) != len(robot):
        raise ValueError(f"{len(performer)} performer frames but {len(robot)} robot frames")
    if not 0 <= lag < len(performer):
        raise ValueError(f"a lag of {lag} frames in a stream of {len(performer)}")
    rows = []
    end = len(performer) - lag
    for name in performer.names:
        if name not in BY_NAME:
            continue
        theirs, ours = performer.column(name)[:end], robot.column(name)[lag:]
        both = np.isfinite(theirs) & np.isfinite(ours)
        count = int(both.sum())
        performer_span = span(performer.column(name))  # moved: over the whole stream
        threshold = moved_threshold(name)
        moved = math.isfinite(performer_span) and performer_span >= threshold
        if count >= MIN_FRAMES:
            their_span, our_span = span(theirs[both]), span(ours[both])
            rho = _pearson(theirs[both], ours[both])
            ratio = our_span / their_span if their_span > 0 else math.nan
        else:
            our_span = span(ours)
            rho, ratio = 0.0, 0.0  # the robot never showed it while the performer did
        box = (reach or {}).get(name)
        in_reach = math.nan
        if box is not None:  # too few frames: 0, as the ratio, where she moves within reach
            shown = ours if count >= MIN_FRAMES else np.zeros_like(theirs)
            in_reach = reach_ratio(theirs, shown, *box)
        rows.append(
            FeatureRow(
                name=name,
                unit=BY_NAME[name].unit,
                frames=count,
                performer_span=performer_span,
                robot_span=our_span if math.isfinite(our_span) else 0.0,
                rho=rho,
                ratio=ratio,
                moved=moved,
                reach_ratio=in_reach,
            )
        )
    return rows


def _reaches(row: FeatureRow) -> bool:
    return (
        math.isfinite(row.ratio)
        and row.ratio >= REACH_RATIO
        and row.robot_span >= REACH_FLOOR * moved_threshold(row.name)
    )


def mark_reach(runs: Sequence[Sequence[FeatureRow]]) -> list[list[FeatureRow]]:
    """The runs of one head (one per profile), each feature marked unreachable when no run
    moves it by :data:`REACH_RATIO` of the performer's span and :data:`REACH_FLOOR` of its
    unit's threshold (or it has too few frames in every run)."""
    reached = {row.name for rows in runs for row in rows if _reaches(row)}
    return [[replace(row, reachable=row.name in reached) for row in rows] for rows in runs]


def best_lag(
    performer: FeatureStream, robot: FeatureStream, max_lag: int = MAX_LAG
) -> tuple[int, float]:
    """The lag (frames, 0..``max_lag``) at which the robot's face follows best, and the mean ρ
    over the moved features there (the performer's frame ``i`` against the robot's
    ``i + lag``); ``(0, nan)`` when nothing is moved."""
    best = (0, math.nan)
    for lag in range(min(max_lag, len(performer) - MIN_FRAMES) + 1):
        rhos = [row.rho for row in compare(performer, robot, lag) if row.moved]
        if not rhos:
            return best
        mean = float(np.mean(rhos))
        if not mean <= best[1]:  # the first, or better
            best = (lag, mean)
    return best


@dataclass(frozen=True)
class Summary:
    """One profile on one head, over the moved features (``moved``), of which ``reachable``
    the head can reach: mean ρ over those it can reach and over all moved, median ratio and
    the share within :data:`RATIO_BAND` over those it can reach (NaN: none to average)."""

    moved: int
    reachable: int
    mean_rho: float
    mean_rho_all: float
    median_ratio: float
    in_band: float


def summarize(rows: Sequence[FeatureRow]) -> Summary:
    """The summary of one run's rows (see :class:`Summary`)."""
    moved = [row for row in rows if row.moved]
    reach = [row for row in moved if row.reachable]
    ratios = [row.ratio for row in reach if math.isfinite(row.ratio)]
    return Summary(
        moved=len(moved),
        reachable=len(reach),
        mean_rho=float(np.mean([row.rho for row in reach])) if reach else math.nan,
        mean_rho_all=float(np.mean([row.rho for row in moved])) if moved else math.nan,
        median_ratio=float(np.median(ratios)) if ratios else math.nan,
        in_band=sum(row.in_band for row in reach) / len(reach) if reach else math.nan,
    )


@dataclass(frozen=True)
class Lead:
    """The figures ``bench robot`` leads with: mean ρ, median ratio and the share of ratios
    within :data:`RATIO_BAND` over ``features``, the features the performer moves that the
    robot moved while babbling (``basis`` ``"babbling"``), or, for a head that was not
    babbled, that some profile moved on it (``"reach"``, :func:`mark_reach`); and the median
    ratio in reach (:func:`reach_ratio`) over those of them that have one (NaN: none)."""

    basis: str
    features: tuple[str, ...]
    mean_rho: float
    median_ratio: float
    in_band: float
    median_reach_ratio: float = math.nan


def lead(rows: Sequence[FeatureRow], babbled: Collection[str] | None) -> Lead:
    """The lead figures of one run's rows: over the moved features the robot moved while
    babbling (``babbled``), or over the moved features it can reach when ``babbled`` is None."""
    if babbled is None:
        chosen = [row for row in rows if row.moved and row.reachable]
    else:
        chosen = [row for row in rows if row.moved and row.name in babbled]
    ratios = [row.ratio for row in chosen if math.isfinite(row.ratio)]
    in_reach = [row.reach_ratio for row in chosen if math.isfinite(row.reach_ratio)]
    return Lead(
        basis="reach" if babbled is None else "babbling",
        features=tuple(sorted(row.name for row in chosen)),
        mean_rho=float(np.mean([row.rho for row in chosen])) if chosen else math.nan,
        median_ratio=float(np.median(ratios)) if ratios else math.nan,
        in_band=sum(row.in_band for row in chosen) / len(chosen) if chosen else math.nan,
        median_reach_ratio=float(np.median(in_reach)) if in_reach else math.nan,
    )
