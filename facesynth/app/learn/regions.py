"""The face's regions and symmetric pairs, from the sweeps: which servos move which features.

Pure numpy. Each sweep step moves one servo alone; its *effect* on a feature is how far the
feature left the neutral, in thresholds (``max(NOISE_K · neutral noise, MIN_CHANGE)``, as
:mod:`facesynth.app.learn.responsive` measures a movement), the largest over the servo's steps.

* Two servos **interact** when both clearly move one feature (each effect >= ``CLEAR``) and
  neither dwarfs the other there (the weaker >= ``SHARED`` of the stronger): a face in which
  both moved cannot be split into what each did. A servo's weak coupling into a feature
  another servo owns is not an interaction: it adds to the face, and recombination
  (:mod:`facesynth.app.learn.recombine`) sums it in.
* A **region** is a connected set of interacting servos (dead ones, which move nothing, are a
  region each); its **features** are those its servos move most.
* A **symmetric pair**: two live servos whose names are mirror images (``left`` / ``right``)
  and which move mirror-image features most (or the same one), e.g. the two lip corners.

:func:`regions_from_sweeps` finds them from a session's samples, for both their users: the
babbling plan babbles each region on its own (:mod:`facesynth.app.learn.adaptive`) and the fit
writes them into the learned file's report and predicts each region's servos from the features
the region moves (:mod:`facesynth.app.learn.regional`). One rule for both: the neutral is the
median of the neutral samples, per feature, over the values seen; a value not seen (NaN) is no
evidence (it moves nothing and measures no noise), never a reason to drop the rest of its face.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from facesynth.app.learn.responsive import AT_NEUTRAL, MIN_CHANGE, NOISE_K

#: A servo clearly moves a feature at this effect (thresholds) …
CLEAR = 2.0
#: … and two servos interact where the weaker moves a feature by this share of the stronger.
SHARED = 0.5
#: A servo *mainly* moves a feature it clearly moves by this share of its largest effect
#: (``Regions.reads``): on simhead18_neck the neck's yaw moves head_yaw by 62 thresholds and
#: the gaze, lid and cheek readings by 2-13.
MAIN = 0.25


@dataclass(frozen=True)
class Regions:
    """The face's regions: servo index groups (profile order within, by first servo), each
    region's features, and the symmetric pairs (servo names)."""

    servos: tuple[str, ...]
    groups: tuple[tuple[int, ...], ...]
    features: tuple[tuple[str, ...], ...]
    pairs: tuple[tuple[str, str], ...]
    #: Per servo, the features an inverse model reads for it (empty: unknown, the whole
    #: face): those it moves *mainly* (clearly, and by at least ``MAIN`` of its largest
    #: effect), and those mainly moved by the servos that mainly move one of them too.
    reads: tuple[tuple[str, ...], ...] = ()

    def notes(self) -> list[str]:
        """One line per region and one for the pairs, for the fit's report."""
        lines = []
        for number, (group, features) in enumerate(zip(self.groups, self.features, strict=True), 1):
            moved = ", ".join(features) if features else "nothing"
            servos = ", ".join(self.servos[i] for i in group)
            lines.append(f"region {number}: {servos} move {moved}")
        pairs = ", ".join(f"{a}/{b}" for a, b in self.pairs) or "none"
        lines.append(f"symmetric pairs: {pairs}")
        return lines


def whole_face(servos: tuple[str, ...]) -> Regions:
    """Every servo in one region: what is known before the sweeps."""
    return Regions(servos, (tuple(range(len(servos))),), ((),), ())


def sweep_effects(faces: np.ndarray, u: np.ndarray, kinds: np.ndarray) -> np.ndarray | None:
    """(S, d): each servo's largest effect on each feature over its sweep steps, in
    thresholds (0 where it has none); None without two neutral samples to measure noise.
    ``faces`` (n, d), raw or relative to any fixed offset (NaN: not seen); ``u`` (n, S)
    normalized. A feature's neutral is the median of its neutral values seen, its threshold
    as :func:`~facesynth.app.learn.responsive.thresholds` from them; a feature seen at fewer
    than two neutral samples, and a value not seen, give no effect."""
    faces = np.asarray(faces, dtype=np.float64)
    u, kinds = np.asarray(u, dtype=np.float64), np.asarray(kinds)
    if faces.ndim != 2 or u.ndim != 2 or not (len(faces) == len(u) == len(kinds)):
        raise ValueError(
            f"faces {faces.shape}, commands {u.shape} and {kinds.shape} kinds do not pair up"
        )
    neutral = faces[kinds == "neutral"]
    if len(neutral) < 2:
        return None
    seen = np.isfinite(neutral)
    measured = seen.sum(axis=0) >= 2
    with warnings.catch_warnings():  # a feature never seen at neutral: measured is False
        warnings.simplefilter("ignore", RuntimeWarning)
        rest = np.nanmedian(neutral, axis=0)
        noise = np.nanstd(neutral, axis=0)
    threshold = np.where(measured, np.maximum(NOISE_K * np.nan_to_num(noise), MIN_CHANGE), 1.0)
    off = np.abs(u) > AT_NEUTRAL
    alone = (kinds == "sweep") & (off.sum(axis=1) == 1)
    effects = np.zeros((u.shape[1], faces.shape[1]))
    for servo in range(u.shape[1]):
        rows = alone & off[:, servo]
        if rows.any():
            change = np.abs(faces[rows] - rest) / threshold
            change = np.where(np.isfinite(change) & measured, change, 0.0)
            effects[servo] = change.max(axis=0)
    return effects


def regions_from_sweeps(
    faces: np.ndarray,
    u: np.ndarray,
    kinds: np.ndarray,
    servos: tuple[str, ...],
    inputs: list[str],
) -> Regions:
    """The face's regions from a session's samples (``faces`` (n, d) over ``inputs``, NaN:
    not seen; ``u`` (n, S) normalized commands of ``servos``; ``kinds``): what the adaptive
    plan babbles and the fit uses. One region of every servo when the sweeps tell nothing
    (no two neutral samples, or no sweep that moved a feature)."""
    if faces.shape[1:] != (len(inputs),) or u.shape[1:] != (len(servos),):
        raise ValueError(
            f"faces {faces.shape} / commands {u.shape} are not over {len(inputs)} inputs / "
            f"{len(servos)} servos"
        )
    effects = sweep_effects(faces, u, kinds)
    if effects is None or not effects.any():
        return whole_face(servos)
    return find_regions(effects, servos, inputs)


def _mirror(name: str) -> str:
    swapped = []
    for part in name.replace("Left", "_L3FT_").replace("Right", "Left").split("_L3FT_"):
        swapped.append(part.replace("left", "\0").replace("right", "left").replace("\0", "right"))
    return "Right".join(swapped)


def find_regions(effects: np.ndarray, servos: tuple[str, ...], inputs: list[str]) -> Regions:
    """The regions and symmetric pairs of ``servos`` from their sweep ``effects`` (S, d) on
    ``inputs`` (see the module)."""
    n = len(servos)
    clear = effects >= CLEAR
    parent = list(range(n))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for a in range(n):
        for b in range(a + 1, n):
            both = clear[a] & clear[b]
            weak = np.minimum(effects[a], effects[b])
            strong = np.maximum(effects[a], effects[b])
            if np.any(both & (weak >= SHARED * strong)):
                parent[root(b)] = root(a)
    members: dict[int, list[int]] = {}
    for servo in range(n):
        members.setdefault(root(servo), []).append(servo)
    groups = tuple(tuple(m) for m in sorted(members.values(), key=lambda m: m[0]))
    live = np.asarray(clear.any(axis=1), dtype=bool)
    owner = np.argmax(effects, axis=0)
    features = tuple(
        tuple(inputs[f] for f in range(len(inputs)) if owner[f] in group and clear[owner[f], f])
        for group in groups
    )
    index = {name: i for i, name in enumerate(servos)}
    main = clear & (effects >= MAIN * effects.max(axis=1, keepdims=True))
    shared = (main.astype(np.int64) @ main.T.astype(np.int64)) > 0  # (S, S): a main feature
    reads = tuple(
        tuple(inputs[f] for f in np.flatnonzero(main[shared[servo]].any(axis=0)))
        for servo in range(n)
    )
    pairs = []
    for a, name in enumerate(servos):
        b = index.get(_mirror(name), -1)
        if b <= a or not (bool(live[a]) and bool(live[b])):
            continue
        top_a, top_b = inputs[int(np.argmax(effects[a]))], inputs[int(np.argmax(effects[b]))]
        if _mirror(top_a) == top_b:
            pairs.append((name, servos[b]))
    return Regions(servos, groups, features, tuple(pairs), reads)
