"""Many training faces from few babbled poses: regions babbled alone, recombined.

Emo's way (Hu et al. 2024: eyes and mouth babbled apart, recombined into 722,400 training
faces). A pose that moves one region's servos only (the others at neutral: a sweep step, a
region pose, the neutral itself) shows what that region does to the face. Where the regions
do not interact (:mod:`facesynth.app.learn.regions`: no feature moved strongly by servos of
two regions), a face with every region moved is, to the camera's precision, the neutral face
plus each region's change: a synthetic pose takes one babbled pose per region, its commands
are their union (each region's servos from its own pose) and its face is the sum of their
changes from the neutral (weak couplings into another region's features are summed in too).
Servos that do interact are one region, babbled and recombined together, so their coupling is
kept as the camera saw it.

Pure numpy. The faces are taken relative to the robot's neutral (``t``); the synthetic ones
are only ever training data: held-out errors are measured on real poses.
"""

from __future__ import annotations

import numpy as np

#: Commands closer to neutral than this count as at neutral (normalized).
AT_NEUTRAL = 1e-6


def region_pools(u: np.ndarray, groups: tuple[tuple[int, ...], ...]) -> list[np.ndarray]:
    """Per region (a tuple of servo indices), the rows of ``u`` (n, S) that move no servo
    outside it: the poses that show that region alone (the neutral poses are in every pool)."""
    off = np.abs(u) > AT_NEUTRAL
    pools = []
    for group in groups:
        outside = np.ones(u.shape[1], dtype=bool)
        outside[list(group)] = False
        pools.append(np.flatnonzero(~off[:, outside].any(axis=1)))
    return pools


def recombine(
    t: np.ndarray,
    u: np.ndarray,
    groups: tuple[tuple[int, ...], ...],
    count: int,
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """``count`` synthetic poses ``(t, u)`` from rows of ``t`` (n, d: faces relative to the
    neutral) and ``u`` (n, S): each draws one row per region from :func:`region_pools` (seeded)
    and sums them. ``(0, d), (0, S)`` when fewer than two regions, or a region with no pose
    that moved it, leave nothing to recombine."""
    pools = region_pools(u, groups)
    moving = [
        pool[np.abs(u[pool][:, list(g)]).max(axis=1) > AT_NEUTRAL]
        for pool, g in zip(pools, groups, strict=True)
    ]
    if len(groups) < 2 or count < 1 or any(len(m) == 0 for m in moving):
        return np.zeros((0, t.shape[1])), np.zeros((0, u.shape[1]))
    rng = np.random.default_rng(seed)
    t_out = np.zeros((count, t.shape[1]))
    u_out = np.zeros((count, u.shape[1]))
    for pool, group in zip(pools, groups, strict=True):
        rows = pool[rng.integers(0, len(pool), count)]
        t_out += t[rows]
        columns = list(group)
        u_out[:, columns] = u[rows][:, columns]
    return t_out, u_out


def babbled_units(
    groups: tuple[tuple[int, ...], ...], u: np.ndarray
) -> tuple[tuple[int, ...], ...]:
    """``groups`` (servo index tuples) merged where the babbling moved them together: a pose
    of ``u`` (n, S) that moves servos of some of the groups, not all, joins them (a region
    pose of a plan that saw the regions a little differently from the fit); poses that move
    every group (whole-face poses) join nothing."""
    off = np.abs(u) > AT_NEUTRAL
    parent = list(range(len(groups)))

    def root(i: int) -> int:
        while parent[i] != i:
            i = parent[i]
        return i

    touched = np.column_stack([off[:, list(g)].any(axis=1) for g in groups])
    for row in touched:
        hit = np.flatnonzero(row)
        if 2 <= len(hit) < len(groups):
            for other in hit[1:]:
                parent[root(int(other))] = root(int(hit[0]))
    merged: dict[int, list[int]] = {}
    for index, group in enumerate(groups):
        merged.setdefault(root(index), []).extend(group)
    return tuple(tuple(sorted(m)) for m in sorted(merged.values(), key=min))
