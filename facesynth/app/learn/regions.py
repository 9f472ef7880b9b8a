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

:func:`find_regions` gives them; the fit writes them into the learned file's report, the
babbling plan babbles each region on its own (:mod:`facesynth.app.learn.adaptive`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from facesynth.app.learn.responsive import AT_NEUTRAL, thresholds

#: A servo clearly moves a feature at this effect (thresholds) …
CLEAR = 2.0
#: … and two servos interact where the weaker moves a feature by this share of the stronger.
SHARED = 0.5


@dataclass(frozen=True)
class Regions:
    """The face's regions: servo index groups (profile order within, by first servo), each
    region's features, and the symmetric pairs (servo names)."""

    servos: tuple[str, ...]
    groups: tuple[tuple[int, ...], ...]
    features: tuple[tuple[str, ...], ...]
    pairs: tuple[tuple[str, str], ...]

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


def sweep_effects(t: np.ndarray, u: np.ndarray, kinds: np.ndarray) -> np.ndarray | None:
    """(S, d): each servo's largest effect on each feature over its sweep steps, in
    thresholds (0 where it has none); None without two neutral samples to measure noise.
    ``t`` (n, d): faces relative to the neutral (NaN: not seen); ``u`` (n, S) normalized."""
    kinds = np.asarray(kinds)
    finite = np.all(np.isfinite(t), axis=1)
    threshold = thresholds(t[finite], kinds[finite])
    if threshold is None:
        return None
    rest = np.median(t[finite & (kinds == "neutral")], axis=0)
    off = np.abs(u) > AT_NEUTRAL
    alone = (kinds == "sweep") & (off.sum(axis=1) == 1) & finite
    effects = np.zeros((u.shape[1], t.shape[1]))
    for servo in range(u.shape[1]):
        rows = alone & off[:, servo]
        if rows.any():
            effects[servo] = (np.abs(t[rows] - rest) / threshold).max(axis=0)
    return effects


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
    pairs = []
    for a, name in enumerate(servos):
        b = index.get(_mirror(name), -1)
        if b <= a or not (bool(live[a]) and bool(live[b])):
            continue
        top_a, top_b = inputs[int(np.argmax(effects[a]))], inputs[int(np.argmax(effects[b]))]
        if _mirror(top_a) == top_b:
            pairs.append((name, servos[b]))
    return Regions(servos, groups, features, tuple(pairs))
