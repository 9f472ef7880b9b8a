"""Feature processor F, pure core: the paper's pose-free features (section 2.2.2) and more.

The two outer eye corners (36, 45) define a face frame: origin at their midpoint, x axis along
the eye line, unit length = their distance (inter-ocular distance, IOD). In that frame the
distance of every point to the nose tip (30) no longer depends on the head's in-plane position,
rotation or scale. When the points come with a 3D mesh (the tracker), the rest of the head's
rotation is taken out first (:func:`paper_frame`, ``services.features.frontal``): the points
are moved rigidly, with the mesh's depth, to the head's pose at the neutral, so a head turned
or nodding does not read as brows lowered. Features are also given relative to the performer's
neutral face: from a calibration, or the median over the first second (media time) in which a
face is seen.

Beyond the paper, once the neutral is known every face frame also carries:

* ``displacements``: each of the 68 points' movement from the neutral in the eye-corner frame
  (IOD units, y up);
* ``raw`` / ``named``: the named features of ``feature_names`` relative to the neutral,
  unscaled / scaled to the calibrated (or default) ranges (``services.features.expressions``);
  gaze goes through the blink/wink rule of ``facesynth.services.features.gaze``.

The neutral covers the 68 distances, the 68 points (for displacements), the named features and
the neutral mesh (the face frame and head-pose origin when points carry a 3D ``mesh468``). A
calibration gives what it has; the first ``neutral_seconds`` with a face give the rest. Named
features come from the mesh when the neutral has one (then a frame without a 3D mesh carries
none: its 2D values would not match the neutral's), else from the 68 points alone (also when a
calibration has a named neutral but no neutral mesh). With
``auto_range=True`` the neutral then follows a rolling median and the ranges adapt
(``facesynth.services.features.autorange``).

A message's point sets are read, and checked, by :mod:`facesynth.services.features.point_sets`.
"""

from __future__ import annotations

import numpy as np

from facesynth.runtime.calibration import Calibration
from facesynth.runtime.landmarks import IRIS10, N_IBUG, NOSE_TIP
from facesynth.schemas.messages import Features, Points
from facesynth.services.features.brow_rest import BROW_NAMED, BROW_POINTS, BrowRest, window_at_rest
from facesynth.services.features.expressions import (
    HEAD,
    default_ranges,
    ranges_from,
    raw_features,
    relative,
    scale,
)
from facesynth.services.features.frame import MIN_IOD_PX, FeatureError, normalise
from facesynth.services.features.frontal import paper_frame
from facesynth.services.features.gaze import SIDES, GazeHold
from facesynth.services.features.neutral import (
    AutoNeutral,
    NeutralFace,
    NeutralWindow,
    Sample,
    neutral_face,
)
from facesynth.services.features.point_sets import (
    N_IRIS,
    blendshape_features,
    blendshape_scores,
    ibug_points,
    mesh_points,
    optional_points,
)
from facesynth.services.features.pose import N_MESH, MeshReference, PoseError, Similarity

__all__ = [
    "MIN_IOD_PX",
    "FeatureError",
    "FeatureProcessor",
    "NeutralEstimator",
    "NeutralFace",
    "Sample",
    "ibug_points",  # facesynth.app.render reads a message's points through here
    "neutral_face",
    "normalise",
    "nose_distances",
    "paper_frame",
]

GAZE = tuple(f"gaze_{side}_{axis}" for side in SIDES for axis in "xy")
#: y of the eye-corner frame points down; displacements (like the named features) use y up.
_Y_UP = np.array([1.0, -1.0])


def nose_distances(normalised: np.ndarray) -> np.ndarray:
    """Distance of every point to the nose tip (the paper's 68 features), in IOD units."""
    offsets = normalised - normalised[NOSE_TIP]
    return np.hypot(offsets[:, 0], offsets[:, 1])


class NeutralEstimator:
    """The neutral face as the median of features over the first ``seconds`` with a face."""

    def __init__(self, seconds: float = 1.0) -> None:
        self._window: NeutralWindow[np.ndarray] = NeutralWindow(seconds)
        self.neutral: np.ndarray | None = None

    @property
    def ready(self) -> bool:
        """Whether the neutral is known."""
        return self.neutral is not None

    def add(self, t_media_ns: int, values: np.ndarray) -> bool:
        """Add one face frame's features; return whether the neutral is now known."""
        if self.neutral is not None:
            return True
        if not self._window.add(t_media_ns, values.copy()):
            return False
        self.neutral = np.median(np.stack(self._window.samples), axis=0)
        self._window.samples = []
        return True


class FeatureProcessor:
    """Points messages in, Features messages out."""

    def __init__(
        self,
        neutral: np.ndarray | None = None,
        neutral_seconds: float = 1.0,
        *,
        calibration: Calibration | None = None,
        auto_range: bool = False,
        neutral_held: bool = False,
    ) -> None:
        """Args:
        neutral: the neutral's 68 nose-tip distances (else the calibration's, else measured).
        neutral_seconds: seconds of face the missing parts of the neutral are measured over.
        calibration: a performer's calibration: neutral distances, named neutral and ranges,
            neutral mesh (each used if present).
        auto_range: adapt the neutral (rolling median) and the ranges to the stream.
        neutral_held: the face is known to be held at its neutral over the first
            ``neutral_seconds`` (a robot's camera while the head is held at neutral): the
            measured neutral is taken as it is, brows included (no ``brow_rest`` search).
        """
        self.estimator = NeutralEstimator(neutral_seconds)
        if calibration is not None and neutral is None:
            neutral = np.asarray(calibration.neutral, dtype=np.float64)
        #: Whether the neutral's distances are measured (none given, none in a calibration).
        self._distances_measured = neutral is None
        if neutral is not None:
            if neutral.shape != (N_IBUG,) or not np.all(np.isfinite(neutral)):
                raise FeatureError("a neutral needs 68 finite distances")
            self.estimator.neutral = neutral.astype(np.float64)
        self.named_neutral: dict[str, float] | None = None
        self.reference: MeshReference | None = None
        self.ranges = default_ranges()
        if calibration is not None:
            if calibration.named_neutral:
                self.named_neutral = dict(calibration.named_neutral)
            if calibration.neutral_mesh:
                mesh = np.asarray(calibration.neutral_mesh, dtype=np.float64)
                self.reference = MeshReference(mesh.reshape(N_MESH, 3))
            self.ranges = ranges_from(calibration.named_min, calibration.named_max)
        #: Whether the named features come from the mesh (a calibration's neutral mesh, or a
        #: calibration's named neutral without one: 2D; otherwise the measured neutral decides).
        self.use_mesh: bool | None = None
        if self.reference is not None:
            self.use_mesh = True
        elif self.named_neutral is not None:
            self.use_mesh = False
        self.frame_neutral: np.ndarray | None = None
        self.window: NeutralWindow[Sample] = NeutralWindow(neutral_seconds)
        self.gaze = GazeHold()
        self.auto_range = auto_range
        self.auto: AutoNeutral | None = None
        #: Whether the brows' part of a neutral F measures may be taken again (``brow_rest``):
        #: never for a calibration's or a given neutral, nor with auto range (it adapts anyway),
        #: nor for a face known to be held at its neutral (a robot's).
        self._brows_may_move = (
            calibration is None and neutral is None and not auto_range and not neutral_held
        )
        #: The search for the brows' neutral while the measured one's brows were not at rest, or
        #: only with the eyes shut.
        self.brows: BrowRest | None = None
        #: What the processor decided that a person should hear of (the shell logs and clears
        #: them): the brows' rest search, its outcome.
        self.notes: list[str] = []

    @classmethod
    def from_calibration(
        cls, calibration: Calibration, *, neutral_seconds: float = 1.0, auto_range: bool = False
    ) -> FeatureProcessor:
        """A processor with a performer's calibration (see ``__init__``)."""
        return cls(neutral_seconds=neutral_seconds, calibration=calibration, auto_range=auto_range)

    def _complete_neutral(self) -> None:
        neutral = neutral_face(
            self.window.samples, self.reference, use_mesh=self.use_mesh is not False
        )
        if neutral.reference is not None:  # the window's points, frontalised against it
            frames = np.stack(
                [paper_frame(s.ibug68, s.mesh, neutral.reference) for s in self.window.samples]
            )
            neutral.frame = np.median(frames, axis=0)
            if self._distances_measured:
                self.estimator.neutral = np.median([nose_distances(f) for f in frames], axis=0)
        rest = window_at_rest(self.window.samples)
        if self._brows_may_move and rest in ("moved", "shut"):
            self.brows = BrowRest(self.window.window_ns / 1e9, provisional=rest == "shut")
            self.notes.append(self.brows.waiting_for())
        self.window.samples = []
        self.frame_neutral = neutral.frame
        self.reference = neutral.reference
        self.use_mesh = neutral.reference is not None
        # Head pose is measured from the reference mesh itself, never offset by a neutral value:
        # a calibration's mesh stays the origin even when the stream starts with a turned head.
        named = {k: v for k, v in neutral.named.items() if k not in HEAD}
        named.update(self.named_neutral or {})  # a calibration's values win
        self.named_neutral = named
        if self.auto_range:
            distances = self.estimator.neutral
            if distances is None:
                distances = nose_distances(neutral.frame)
            self.auto = AutoNeutral(named, distances, neutral.frame, self.ranges)

    def process(self, points: Points) -> Features:
        """Features of one frame; raise :class:`FeatureError` for unusable points."""
        if not points.face:
            return Features(
                seq=points.seq,
                t_capture_ns=points.t_capture_ns,
                t_media_ns=points.t_media_ns,
                face=False,
                neutral_ready=self.estimator.ready,
                capture_host=points.capture_host,
            )
        ibug = ibug_points(points)
        mesh = mesh_points(points)
        fits = self._fits(mesh)
        frame = paper_frame(ibug, mesh, self.reference, fits[0] if fits else None)
        iris = optional_points(points, IRIS10, N_IRIS, 2)
        scores = blendshape_scores(points)
        distances = nose_distances(frame)
        t = points.t_media_ns
        ready = self.estimator.add(t, distances)
        if self.frame_neutral is None or self.brows is not None:  # a neutral being learned
            sample = Sample(ibug, frame, mesh, iris, scores)
            if self.frame_neutral is None and self.window.add(t, sample):
                self._complete_neutral()
                fits = self._fits(mesh)
                if self.reference is not None:  # this frame was read before the neutral mesh
                    frame = paper_frame(ibug, mesh, self.reference, fits[0] if fits else None)
                    distances = nose_distances(frame)
            elif self.brows is not None:
                found = self.brows.add(t, sample)
                if found is not None:
                    if found.samples:
                        self._rebase_brows(found.samples)
                    self.notes.append(found.note(t))
                    if found.final:
                        self.brows = None
        distance_neutral = self.estimator.neutral if ready else None
        frame_neutral = self.frame_neutral
        named: dict[str, float] = {}
        rel: dict[str, float] = {}
        raw = self._raw(ibug, mesh, iris, scores, fits[1] if fits else None)
        if raw is not None and self.named_neutral is not None:
            named_neutral = self.named_neutral if self.auto is None else self.auto.named
            self.gaze.observe(raw, named_neutral)
            if self.auto is not None:
                named_neutral, auto_distances, frame_neutral = self.auto.update(
                    t, self._learnable(raw), distances, frame
                )
                if distance_neutral is not None:
                    distance_neutral = auto_distances
            rel = relative(raw, named_neutral)
            held = self.gaze.hold(rel)
            for key in GAZE:
                rel.pop(key, None)
            rel.update(held)
            if self.brows is not None and not self.brows.known:  # no rest yet: hold them
                rel.update((name, 0.0) for name in BROW_NAMED if name in rel)
            ranges = self.ranges if self.auto is None else self.auto.range.update(t, rel)
            named = scale(rel, ranges)
        delta = distances - distance_neutral if distance_neutral is not None else None
        moved = (frame - frame_neutral) * _Y_UP if frame_neutral is not None else None
        if self.brows is not None and not self.brows.known:  # and their points' deltas
            for array in (delta, moved):
                if array is not None:
                    array[BROW_POINTS] = 0.0
        deltas = delta.tolist() if delta is not None else []
        displacements = moved.ravel().tolist() if moved is not None else []
        return Features(
            seq=points.seq,
            t_capture_ns=points.t_capture_ns,
            t_media_ns=t,
            face=True,
            neutral_ready=ready,
            distances=distances.tolist(),
            deltas=deltas,
            named=named,
            raw=rel,
            displacements=displacements,
            capture_host=points.capture_host,
        )

    def _rebase_brows(self, samples: list[Sample]) -> None:
        """Take the brows' part of the neutral from ``samples`` (brows at rest)."""
        rest = neutral_face(samples, self.reference, use_mesh=self.use_mesh is not False)
        if self.named_neutral is not None:
            self.named_neutral.update(
                (name, value) for name, value in rest.named.items() if name in BROW_NAMED
            )
        if self.frame_neutral is not None:
            self.frame_neutral = self.frame_neutral.copy()
            self.frame_neutral[BROW_POINTS] = rest.frame[BROW_POINTS]
        if self.estimator.neutral is not None:
            distances = np.median(np.stack([nose_distances(s.frame) for s in samples]), axis=0)
            self.estimator.neutral = self.estimator.neutral.copy()
            self.estimator.neutral[BROW_POINTS] = distances[BROW_POINTS]

    def _fits(self, mesh: np.ndarray | None) -> tuple[Similarity, Similarity] | None:
        """This frame's mesh fitted onto the neutral mesh, both ways at once (``paper_frame``'s
        and ``raw_features``' fits: ``MeshReference.fits``); None without a mesh or a neutral
        mesh, or for a mesh the fit cannot use (the two then find that out as before)."""
        if mesh is None or self.reference is None:
            return None
        try:
            return self.reference.fits(mesh)
        except PoseError:
            return None

    def _raw(
        self,
        ibug: np.ndarray,
        mesh: np.ndarray | None,
        iris: np.ndarray | None,
        scores: np.ndarray | None,
        transform: Similarity | None = None,
    ) -> dict[str, float] | None:
        """Absolute named values (geometry and blendshapes), or None when the neutral cannot
        place them. ``transform``: the mesh's fit onto the neutral's face frame, if known."""
        if self.use_mesh is None:
            return None
        try:
            if self.use_mesh:
                if mesh is None or self.reference is None:
                    return None  # the neutral is in the mesh's frame: 2D values would not match
                raw = raw_features(ibug, mesh, iris, self.reference, transform)
            else:
                raw = raw_features(ibug, None, iris)
        except FeatureError:  # a degenerate mesh: this frame has the paper's features only
            return None
        raw.update(blendshape_features(scores))
        return raw

    def _learnable(self, raw: dict[str, float]) -> dict[str, float]:
        """Raw values the rolling neutral may learn from: no gaze of a closed eye."""
        learn = dict(raw)
        for side in SIDES:
            if self.gaze.closed[side]:
                learn.pop(f"gaze_{side}_x", None)
                learn.pop(f"gaze_{side}_y", None)
        return learn
