"""services.translator.sources.GroupMeans: a frame's point groups averaged at once, bit for bit
as each group's own ``deltas[group].mean()`` (T's commands must not change by a rounding)."""

from __future__ import annotations

import numpy as np

from facesynth.runtime.landmarks import N_IBUG
from facesynth.services.translator.sources import GroupMeans


def _groups(rng: np.random.Generator) -> list[tuple[int, ...]]:
    """Groups of every size 1..68 (past numpy's 8-wide pairwise summation), some with a
    point twice, some sizes several times."""
    groups = []
    for size in [*range(1, N_IBUG + 1), 2, 3, 4, 8, 9, 17]:
        points = rng.choice(N_IBUG, size=size, replace=False).tolist()
        groups.append(tuple(points))
    groups += [(5, 5), (36, 37, 36, 40, 41, 36, 38, 39, 36)]
    return groups


def test_every_group_mean_is_numpys_own_bit_for_bit() -> None:
    rng = np.random.default_rng(28)
    groups = _groups(rng)
    means = GroupMeans(groups)
    for frame in range(60):
        scale = 10.0 ** rng.uniform(-6, 3)  # tiny to large deltas: rounding differs by scale
        deltas = rng.normal(0.0, scale, N_IBUG)
        if frame % 10 == 0:  # a non-finite delta propagates as numpy's mean propagates it
            deltas[rng.integers(N_IBUG)] = [np.nan, np.inf, -np.inf][frame // 10 % 3]
        got = means(deltas)
        assert set(got) == set(groups)
        for group in groups:
            expected = float(deltas[np.asarray(group, dtype=np.intp)].mean())
            assert np.array_equal(got[group], expected, equal_nan=True), (group, frame)
            assert np.signbit(got[group]) == np.signbit(expected)


def test_a_group_listed_twice_is_averaged_once_and_an_empty_one_is_left_out() -> None:
    means = GroupMeans([(1, 2), (), (1, 2), (3,)])
    deltas = np.arange(N_IBUG, dtype=np.float64)
    assert means(deltas) == {(1, 2): 1.5, (3,): 3.0}


def test_negative_zero_stays_negative_zero() -> None:
    deltas = np.zeros(N_IBUG)
    deltas[[4, 7]] = -0.0
    got = GroupMeans([(4, 7)])(deltas)[(4, 7)]
    assert got == 0.0 and np.signbit(got) == np.signbit(deltas[[4, 7]].mean())
