"""Calibration recorder, pure core: frames of guided steps in, a :class:`Calibration` out.

The performer holds each of the paper's face-section expressions for a few seconds (or a video
schedule says when each happens). The neutral step gives the neutral face: the median of its
nose-tip distances, of its mesh and of its named features. Every other frame, relative to that
neutral, widens the movement ranges: per step, a robust low and high (``low_pct`` and
``high_pct`` percentiles of the step's frames after the first ``settle_s`` seconds, which are the
transition into the expression), and over all steps the widest.
"""

from __future__ import annotations

import itertools
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from facesynth.runtime.calibration import Calibration
from facesynth.runtime.feature_names import BY_NAME
from facesynth.runtime.landmarks import IRIS10, N_IBUG
from facesynth.schemas.messages import Points
from facesynth.services.features.core import FeatureError, nose_distances, paper_frame
from facesynth.services.features.expressions import relative
from facesynth.services.features.point_sets import (
    blendshape_features,
    blendshape_scores,
    ibug_points,
    mesh_points,
    optional_points,
)
from facesynth.services.features.pose import MeshReference

#: The paper's face-section expressions (section 3.2.1), in the order they are asked for.
STEPS: tuple[str, ...] = (
    "neutral",
    "raise_eyebrows",
    "frown",
    "look_left",
    "look_right",
    "look_up",
    "look_down",
    "raise_cheeks",
    "open_mouth",
    "smile",
)

PROMPTS: dict[str, str] = {
    "neutral": "relax your face and look straight at the camera",
    "raise_eyebrows": "raise both eyebrows as high as you can",
    "frown": "frown: pull your eyebrows down and together",
    "look_left": "keep your head still and look to YOUR left",
    "look_right": "keep your head still and look to YOUR right",
    "look_up": "keep your head still and look up",
    "look_down": "keep your head still and look down",
    "raise_cheeks": "squint: raise your cheeks",
    "open_mouth": "open your mouth wide",
    "smile": "smile broadly",
}

#: A named feature that barely moved keeps at least this share of its default range.
MIN_SPAN_SHARE = 0.25

#: Absolute named features of one frame: (ibug68, mesh, iris, neutral mesh reference or None).
#: The blendshape features (``full`` tracker model) are added to what it returns.
NamedExtractor = Callable[..., dict[str, float]]


class CalibrationStepError(ValueError):
    """A schedule or recording that cannot give a calibration."""


@dataclass
class _Frame:
    t_s: float
    ibug: np.ndarray
    mesh: np.ndarray | None
    iris: np.ndarray | None
    scores: np.ndarray | None = None


@dataclass
class StepRecording:
    """The usable frames of one step."""

    name: str
    frames: list[_Frame] = field(default_factory=list)
    seen: int = 0


def parse_schedule(text: str) -> list[tuple[str, float, float]]:
    """``"neutral=9.6-10.4,smile=14-15"`` → ``[(step, start_s, end_s), …]`` in time order."""
    schedule = []
    for part in filter(None, (p.strip() for p in text.split(","))):
        match = re.fullmatch(r"([a-z_]+)=(\d+(?:\.\d+)?)-(\d+(?:\.\d+)?)", part)
        if not match:
            raise CalibrationStepError(f"schedule entry {part!r} is not STEP=START-END (seconds)")
        step, start, end = match.group(1), float(match.group(2)), float(match.group(3))
        if step not in STEPS:
            raise CalibrationStepError(f"unknown step {step!r}; steps: {', '.join(STEPS)}")
        if not end > start:
            raise CalibrationStepError(f"schedule entry {part!r} ends before it starts")
        schedule.append((step, start, end))
    if not any(step == "neutral" for step, _, _ in schedule):
        raise CalibrationStepError("the schedule needs a neutral step")
    schedule.sort(key=lambda entry: entry[1])
    for (a, _, a_end), (b, b_start, _) in itertools.pairwise(schedule):
        if b_start < a_end:
            raise CalibrationStepError(f"steps {a!r} and {b!r} overlap")
    return schedule


def step_at(schedule: list[tuple[str, float, float]], t_s: float) -> tuple[str, float] | None:
    """The step a time falls in and the time since that step began, or ``None``."""
    for step, start, end in schedule:
        if start <= t_s < end:
            return step, t_s - start
    return None


def _point_set(points: Points, scheme: str, count: int, dims: int) -> np.ndarray | None:
    """A set as F reads it; a malformed one counts as absent (the frame still calibrates)."""
    try:
        return optional_points(points, scheme, count, dims)
    except FeatureError:
        return None


class CalibrationRecorder:
    """Collects frames per step and turns them into a calibration."""

    def __init__(
        self,
        name: str,
        extract_named: NamedExtractor,
        *,
        settle_s: float = 0.7,
        low_pct: float = 5.0,
        high_pct: float = 95.0,
    ) -> None:
        self.name = name
        self.extract_named = extract_named
        self.settle_s = settle_s
        self.low_pct, self.high_pct = low_pct, high_pct
        self.steps: dict[str, StepRecording] = {}

    def add(self, step: str, t_in_step_s: float, points: Points) -> bool:
        """Record one frame of ``step``; return whether it was used (face, past settling)."""
        recording = self.steps.setdefault(step, StepRecording(step))
        recording.seen += 1
        if not points.face or t_in_step_s < self.settle_s:
            return False
        try:
            ibug = ibug_points(points)
        except FeatureError:
            return False
        try:
            mesh = mesh_points(points)
        except FeatureError:  # a malformed mesh counts as absent (the frame still calibrates)
            mesh = None
        iris = _point_set(points, IRIS10, 10, 2)
        try:
            scores = blendshape_scores(points)
        except FeatureError:  # malformed scores count as absent, like a malformed mesh
            scores = None
        recording.frames.append(_Frame(t_in_step_s, ibug, mesh, iris, scores))
        return True

    def summary(self) -> dict[str, tuple[int, int]]:
        """Per step: (frames used, frames seen)."""
        return {name: (len(r.frames), r.seen) for name, r in self.steps.items()}

    def build(self, created: str = "") -> Calibration:
        """The calibration; raise :class:`CalibrationStepError` without a usable neutral."""
        neutral_step = self.steps.get("neutral")
        if neutral_step is None or len(neutral_step.frames) < 3:
            raise CalibrationStepError(
                "the neutral step has fewer than 3 usable frames with a face "
                "(live: hold still facing the camera; video: widen the neutral segment)"
            )
        neutral_frames = neutral_step.frames
        meshes = [f.mesh for f in neutral_frames if f.mesh is not None]
        neutral_mesh = np.median(np.stack(meshes), axis=0) if len(meshes) >= 3 else None
        reference = MeshReference(neutral_mesh) if neutral_mesh is not None else None
        neutral = np.median([_distances(f.ibug, f.mesh, reference) for f in neutral_frames], axis=0)
        named_neutral = _median_named([self._named(f, reference) for f in neutral_frames])
        lows = np.zeros(N_IBUG)
        highs = np.zeros(N_IBUG)
        named_low: dict[str, float] = {}
        named_high: dict[str, float] = {}
        for recording in self.steps.values():
            if not recording.frames:
                continue
            deltas = np.stack(
                [_distances(f.ibug, f.mesh, reference) - neutral for f in recording.frames]
            )
            lows = np.minimum(lows, np.percentile(deltas, self.low_pct, axis=0))
            highs = np.maximum(highs, np.percentile(deltas, self.high_pct, axis=0))
            rows = [relative(self._named(f, reference), named_neutral) for f in recording.frames]
            for name in set().union(*rows):
                values = np.array([row[name] for row in rows if name in row])
                low = float(np.percentile(values, self.low_pct))
                high = float(np.percentile(values, self.high_pct))
                named_low[name] = min(named_low.get(name, 0.0), low)
                named_high[name] = max(named_high.get(name, 0.0), high)
        named_min, named_max = _named_ranges(named_low, named_high)
        return Calibration(
            name=self.name,
            neutral=neutral.tolist(),
            delta_min=np.minimum(lows, 0.0).tolist(),
            delta_max=np.maximum(highs, 0.0).tolist(),
            created=created,
            named_neutral={k: v for k, v in named_neutral.items() if not k.startswith("head_")},
            named_min=named_min,
            named_max=named_max,
            neutral_mesh=neutral_mesh.ravel().tolist() if neutral_mesh is not None else [],
        )

    def _named(self, frame: _Frame, reference: MeshReference | None) -> dict[str, float]:
        """Absolute named values of a frame: its geometry, then its blendshapes."""
        named = self.extract_named(frame.ibug, frame.mesh, frame.iris, reference)
        named.update(blendshape_features(frame.scores))
        return named


def _distances(
    ibug: np.ndarray, mesh: np.ndarray | None, reference: MeshReference | None
) -> np.ndarray:
    """The paper's distances, the head's rotation since the neutral mesh taken out (F's way)."""
    return nose_distances(paper_frame(ibug, mesh, reference))


def _median_named(rows: list[dict[str, float]]) -> dict[str, float]:
    names = set().union(*rows) if rows else set()
    return {name: float(np.median([row[name] for row in rows if name in row])) for name in names}


def _named_ranges(
    low: Mapping[str, float], high: Mapping[str, float]
) -> tuple[dict[str, float], dict[str, float]]:
    """Observed extremes, each at least ``MIN_SPAN_SHARE`` of the default range wide."""
    named_min, named_max = {}, {}
    for name in set(low) | set(high):
        feature = BY_NAME.get(name)
        if feature is None:
            continue
        named_min[name] = min(low.get(name, 0.0), MIN_SPAN_SHARE * feature.default_min)
        named_max[name] = max(high.get(name, 0.0), MIN_SPAN_SHARE * feature.default_max)
    return named_min, named_max
