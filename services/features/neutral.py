"""The performer's neutral face from face frames, and its automatic (rolling) variant.

Pure numpy. :func:`neutral_face` takes per-value medians of some frames (the first second with
a face, or a calibration's neutral step); :class:`AutoNeutral` keeps a rolling neutral and
adaptive ranges for ``FeatureProcessor(auto_range=True)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Generic, TypeVar

import numpy as np

from facesynth.runtime.blendshapes import SHAPES
from facesynth.runtime.feature_names import NAMES
from facesynth.runtime.landmarks import N_IBUG
from facesynth.services.features.autorange import AutoRange, RollingNeutral
from facesynth.services.features.expressions import raw_features
from facesynth.services.features.frame import FeatureError
from facesynth.services.features.pose import (
    MIN_SCALE,
    STABLE_VERTICES,
    MeshReference,
    face_axes,
    median_mesh,
)

T = TypeVar("T")

STABLE = np.asarray(STABLE_VERTICES)


@dataclass(frozen=True)
class Sample:
    """One face frame's landmarks: 68 image points, their eye-corner frame, mesh, iris, and
    the 52 blendshape scores (``full`` tracker model)."""

    ibug68: np.ndarray
    frame: np.ndarray
    mesh: np.ndarray | None = None
    iris: np.ndarray | None = None
    blendshapes: np.ndarray | None = None


@dataclass
class NeutralFace:
    """A neutral face: 68 points in the eye-corner frame, named raw values, neutral mesh."""

    frame: np.ndarray
    named: dict[str, float]
    reference: MeshReference | None


def _usable_mesh(mesh: np.ndarray) -> bool:
    """Whether a mesh has a face frame and stable vertices to align on."""
    try:
        face_axes(mesh)
    except FeatureError:
        return False
    stable = mesh[STABLE]
    spread = float(((stable - stable.mean(axis=0)) ** 2).sum())
    return bool(np.isfinite(spread)) and spread > MIN_SCALE


def neutral_face(
    samples: list[Sample], reference: MeshReference | None = None, *, use_mesh: bool = True
) -> NeutralFace:
    """The neutral of some face frames: per value medians.

    The named features are read against ``reference`` if given, else against the median of the
    samples' meshes (each aligned onto the first), which becomes the neutral mesh; with no
    usable mesh (or ``use_mesh=False``) there is none and the named features are the 2D ones.
    Samples whose landmarks are degenerate are skipped. A calibration recorder can call
    this on the frames of its neutral step.
    """
    if not samples:
        raise FeatureError("no face frames to take a neutral from")
    if not use_mesh:
        reference = None
    elif reference is None:
        meshes = [s.mesh for s in samples if s.mesh is not None and _usable_mesh(s.mesh)]
        if meshes:
            reference = MeshReference(median_mesh(meshes))
    values: dict[str, list[float]] = {}
    for sample in samples:
        if reference is not None and sample.mesh is None:
            continue
        try:
            mesh = sample.mesh if reference is not None else None
            raw = raw_features(sample.ibug68, mesh, sample.iris, reference)
        except FeatureError:
            continue
        if sample.blendshapes is not None:
            raw.update(zip(SHAPES, sample.blendshapes[1:].tolist(), strict=True))
        for name, value in raw.items():
            values.setdefault(name, []).append(value)
    frame = np.median(np.stack([s.frame for s in samples]), axis=0)
    return NeutralFace(frame=frame, named=medians(values), reference=reference)


def medians(values: dict[str, list[float]]) -> dict[str, float]:
    """``float(np.median(v))`` of each list, bit for bit. The lists as long as the longest (as
    a rule, every name has a value in every frame) are taken as one matrix, one median call for
    all ~80 names instead of one each (numpy's overhead per call was most of a neutral's cost);
    any shorter list on its own."""
    longest = max((len(v) for v in values.values()), default=0)
    whole = [name for name, v in values.items() if len(v) == longest]
    out: dict[str, float] = {}
    if whole:
        matrix = np.array([values[name] for name in whole], dtype=np.float64)
        out = dict(zip(whole, np.median(matrix, axis=1).tolist(), strict=True))
    return {name: out[name] if name in out else float(np.median(v)) for name, v in values.items()}


class NeutralWindow(Generic[T]):
    """Face frames of the first ``seconds`` of media time with a face (at least one frame).

    The one rule for "the first second": F's distance neutral (``NeutralEstimator``) and its
    named/mesh neutral both collect through it.
    """

    def __init__(self, seconds: float) -> None:
        if not seconds > 0:
            raise ValueError("the neutral window must be longer than zero seconds")
        self.window_ns = int(seconds * 1e9)
        self.start_ns: int | None = None
        self.samples: list[T] = []

    def add(self, t_media_ns: int, sample: T) -> bool:
        """Add a frame; True once the window is complete (this frame not included)."""
        if self.start_ns is None:
            self.start_ns = t_media_ns
        if t_media_ns - self.start_ns < self.window_ns or not self.samples:
            self.samples.append(sample)
            return False
        return True


class AutoNeutral:
    """Auto mode: rolling neutral of named values, distances and points; adaptive ranges."""

    def __init__(
        self,
        named: dict[str, float],
        distances: np.ndarray,
        frame: np.ndarray,
        ranges: dict[str, tuple[float, float]],
    ) -> None:
        values = np.array([named.get(name, math.nan) for name in NAMES])
        self.rolling = RollingNeutral(np.concatenate([values, distances, frame.ravel()]))
        self.range = AutoRange(NAMES, ranges)
        #: The named neutral as of the last update.
        self.named = dict(named)

    def update(
        self, t_ns: int, raw: dict[str, float], distances: np.ndarray, frame: np.ndarray
    ) -> tuple[dict[str, float], np.ndarray, np.ndarray]:
        """Feed one frame; return the neutral's named values, distances and 68 points."""
        values = np.array([raw.get(name, math.nan) for name in NAMES])
        vector = self.rolling.add(t_ns, np.concatenate([values, distances, frame.ravel()]))
        n = len(NAMES)
        self.named = {
            name: float(v) for name, v in zip(NAMES, vector[:n], strict=True) if math.isfinite(v)
        }
        return self.named, vector[n : n + N_IBUG], vector[n + N_IBUG :].reshape(N_IBUG, 2)
