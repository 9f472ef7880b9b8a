"""A babbling plan that learns from what it has seen: fine sweeps, regions, least-sure poses.

Where :class:`~facesynth.app.learn.plan.Plan` fills the space with random poses after its
sweeps, :class:`AdaptivePlan` spends the same poses where they teach the fit most:

1. the neutral and **fine sweeps**: each servo alone in ``sweep_steps`` steps each way (6:
   dead bands and saturation known to a sixth of the travel, not a third);
2. ``region_poses`` **region poses**: the sweeps seen so far give the face's regions
   (:func:`~facesynth.app.learn.regions.regions_from_sweeps`, as the fit finds them); each
   pose moves one region's servos (uniform random, the others at neutral), regions drawn in
   proportion to their live servos, so the fit can recombine them into many training faces
   (:mod:`facesynth.app.learn.recombine`);
3. then, in batches of ``batch``, the **least-sure poses**: of ``candidates`` random whole-face
   poses, those on which an ensemble of self-models fitted on every pose so far disagrees
   most (:mod:`facesynth.app.learn.ensemble`). They also cover the interactions between
   regions that region poses never show.

A neutral every ``neutral_every`` poses and the limit on extremes are the base plan's. The
plan must be told each settled pose's face, in order (:meth:`observe`); pose ``i`` depends on
the seed and on the poses and faces before it only, so a resumed run that replays its
session's samples computes the same plan.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from facesynth.app.learn.ensemble import least_sure
from facesynth.app.learn.plan import Plan, PlanError, PlanOptions, Pose, PoseSequence
from facesynth.app.learn.regions import Regions, regions_from_sweeps, whole_face


@dataclass(frozen=True)
class AdaptiveOptions:
    """How the adaptive plan is made (see the module)."""

    seed: int = 0
    sweep_steps: int = 6
    neutral_every: int = 25
    max_extreme_run: int = 2
    region_poses: int = 250
    batch: int = 25
    candidates: int = 400
    members: int = 5

    def __post_init__(self) -> None:
        if self.region_poses < 0 or self.batch < 1 or self.candidates < self.batch:
            raise PlanError("region poses >= 0, batches >= 1 and candidates >= the batch")
        if self.members < 2:
            raise PlanError("an ensemble needs at least two members")


class AdaptivePlan(PoseSequence):
    """The poses of an adaptive babbling session for ``servos`` (see the module)."""

    def __init__(
        self, servos: tuple[str, ...], inputs: list[str], options: AdaptiveOptions | None = None
    ) -> None:
        super().__init__()
        self.options = options or AdaptiveOptions()
        o = self.options
        self.servos = servos
        self.inputs = inputs
        self.base = Plan(
            len(servos), PlanOptions(o.seed, o.sweep_steps, o.neutral_every, o.max_extreme_run)
        )
        self._u: list[np.ndarray] = []
        self._faces: list[np.ndarray] = []
        self._kinds: list[str] = []
        self._regions: Regions | None = None
        self._queue: list[np.ndarray] = []
        self._made = 0  # poses made after the sweeps (neutral checks aside)

    @property
    def regions(self) -> Regions:
        """The regions the plan babbles (found when the first region pose is made)."""
        return self._regions or whole_face(self.servos)

    def observe(self, kind: str, u: np.ndarray, face: np.ndarray) -> None:
        """The settled face (one value per input, NaN: not seen) of the next pose taken."""
        self._kinds.append(kind)
        self._u.append(np.asarray(u, dtype=np.float64))
        self._faces.append(np.asarray(face, dtype=np.float64))

    @property
    def observed(self) -> int:
        """How many poses' faces the plan has been told."""
        return len(self._kinds)

    def seen(self, pose: Pose, features: Mapping[str, float]) -> None:
        """:meth:`observe` pose ``pose`` (the next to be told) with its raw features over the
        plan's inputs (empty: a pose skipped, its face not seen)."""
        if pose.index != self.observed:
            raise PlanError(f"pose {pose.index} told while pose {self.observed} is the next")
        face = np.array([features.get(name, np.nan) for name in self.inputs], dtype=np.float64)
        self.observe(pose.kind, np.array(pose.u), face)

    def replay(self, faces: Mapping[int, Mapping[str, float]], upto: int) -> None:
        """A resumed session's poses ``0 … upto - 1`` and their faces (by pose index; a pose
        with none was skipped) told in order, so that the plan continues as it would have."""
        for index in range(self.observed, upto):
            self.seen(self.pose(index), faces.get(index, {}))

    def _next(self, index: int) -> Pose:
        base = self.base
        if index < base.sweep_poses or index % self.options.neutral_every == 0:
            return base.pose(index)
        self._made += 1
        if self._made <= self.options.region_poses:
            return base.limit(index, "random", self._region_pose(index))
        if not self._queue:
            self._queue = self._least_sure_batch(index)
        return base.limit(index, "random", self._queue.pop(0))

    def _data(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        n = len(self._kinds)
        u = np.array(self._u).reshape(n, len(self.servos))
        faces = np.array(self._faces).reshape(n, len(self.inputs))
        return u, faces, np.array(self._kinds)

    def _region_pose(self, index: int) -> np.ndarray:
        if self._regions is None:
            u, faces, kinds = self._data()
            self._regions = regions_from_sweeps(faces, u, kinds, self.servos, self.inputs)
        regions = self._regions
        weights = np.array(
            [len(g) if f else 0 for g, f in zip(regions.groups, regions.features, strict=True)],
            dtype=np.float64,
        )
        if weights.sum() == 0:
            weights = np.array([len(g) for g in regions.groups], dtype=np.float64)
        rng = np.random.default_rng([self.options.seed, index])
        group = regions.groups[int(rng.choice(len(weights), p=weights / weights.sum()))]
        out = np.zeros(len(self.servos))
        out[list(group)] = rng.uniform(-1.0, 1.0, len(group))
        return out

    def _least_sure_batch(self, index: int) -> list[np.ndarray]:
        rng = np.random.default_rng([self.options.seed, index, 1])
        candidates = rng.uniform(-1.0, 1.0, (self.options.candidates, len(self.servos)))
        u, faces, _ = self._data()
        seen = np.isfinite(faces).mean(axis=0) >= 0.9 if len(faces) else np.zeros(0, bool)
        chosen = least_sure(
            u, faces[:, seen], candidates, self.options.batch, self.options.members, index
        )
        return [candidates[i] for i in chosen]
