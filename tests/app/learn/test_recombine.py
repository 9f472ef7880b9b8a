"""Recombining region poses into training faces (facesynth.app.learn.recombine): each region's
servos come from one babbled pose, coupled servos stay together, and on a head whose regions
do not interact the recombined face is the face the head makes."""

from __future__ import annotations

import numpy as np

from facesynth.app.learn.recombine import recombine, region_pools

#: Servos 0 and 1 interact (feature 0 is their product): one region; servo 2 is another.
GROUPS = ((0, 1), (2,))


def _head(u: np.ndarray) -> np.ndarray:
    """Features of a head: region (0, 1) moves features 0-1 (non-additively within itself),
    region (2,) moves feature 2 and a little of feature 1 (additive coupling across)."""
    return np.column_stack([u[:, 0] * (1.0 + u[:, 1]), u[:, 1] + 0.2 * u[:, 2], np.tanh(u[:, 2])])


def _region_babble(seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    u = np.zeros((72, 3))
    u[:30, :2] = rng.uniform(-1, 1, (30, 2))  # region (0, 1) alone
    levels = (-1, -0.5, -0.2, 0.2, 0.5, 1)
    u[30:36, 0] = u[36:42, 1] = levels  # sweeps of servos 0 and 1
    u[42:67, 2] = rng.uniform(-1, 1, 25)  # region (2,) alone
    u[67:] = rng.uniform(-1, 1, (5, 3))  # whole-face poses: in no pool
    return _head(u), u


def test_pools_hold_the_poses_that_move_one_region_only() -> None:
    _, u = _region_babble()
    u[0] = 0.0  # a neutral pose shows every region at rest
    first, second = region_pools(u, GROUPS)
    assert set(first) == set(range(42))
    assert set(second) == {0, *range(42, 67)}


def test_recombined_faces_are_the_faces_the_head_makes() -> None:
    t, u = _region_babble()
    t_new, u_new = recombine(t, u, GROUPS, 500, seed=1)
    assert t_new.shape == (500, 3) and u_new.shape == (500, 3)
    np.testing.assert_allclose(t_new, _head(u_new), atol=1e-12)
    # every recombined pose moves both regions (no neutral pose in these pools)
    assert np.all(np.abs(u_new[:, :2]).max(axis=1) > 0) and np.all(u_new[:, 2] != 0)


def test_coupled_servos_stay_together() -> None:
    t, u = _region_babble()
    _, u_new = recombine(t, u, GROUPS, 300, seed=2)
    babbled = {tuple(row) for row in np.round(u[:42, :2], 12)}
    assert {tuple(row) for row in np.round(u_new[:, :2], 12)} <= babbled
    # Split apart, the interacting servos would give faces the head never makes:
    t_split, u_split = recombine(t, u, ((0,), (1,), (2,)), 300, seed=2)
    assert np.abs(t_split - _head(u_split)).max() > 0.1


def test_nothing_to_recombine() -> None:
    t, u = _region_babble()
    assert recombine(t, u, ((0, 1, 2),), 100)[0].shape == (0, 3)  # one region
    assert recombine(t, u, GROUPS, 0)[0].shape == (0, 3)
    only_first = u.copy()
    only_first[:, 2] = 0.0  # region (2,) never moved
    assert recombine(t, only_first, GROUPS, 100)[1].shape == (0, 3)


def test_the_fit_trains_on_faces_recombined_from_the_regions() -> None:
    from synthetic_babble import hardware

    from facesynth.app.learn.dataset import BabbleSet
    from facesynth.app.learn.fit import FitOptions, fit_learned_profile
    from facesynth.runtime.feature_names import NAMES

    profile = hardware()
    rng = np.random.default_rng(0)
    inputs = tuple(n for n in NAMES if not n.startswith("head_"))[:16]
    rows, kinds = [], []
    for index in range(400):
        u = np.zeros(16)
        if index % 20 == 0:
            kind = "neutral"
        elif index <= 16 * 6:
            kind = "sweep"  # each servo alone, three steps each way
            servo, step = divmod(index - 1 - index // 20, 6)
            u[servo % 16] = (-1, -2 / 3, -1 / 3, 1 / 3, 2 / 3, 1)[step]
        else:
            kind = "random"  # one half of the face at a time
            half = slice(0, 8) if index % 2 else slice(8, 16)
            u[half] = rng.uniform(-1, 1, 8)
        rows.append(u)
        kinds.append(kind)
    u = np.array(rows)
    # servo i moves feature i, and every feature of its half of the face: two regions
    block = np.kron(np.eye(2), np.full((8, 8), 0.25)) + 0.5 * np.eye(16)
    faces = np.tanh(u @ block) * 0.1 + rng.normal(0.0, 0.001, u.shape)
    commands = 1500.0 + 500.0 * u
    babble = BabbleSet(tuple(s.name for s in profile.servos), commands, inputs, faces, tuple(kinds))
    options = FitOptions(candidates=("poly_ridge",), recombined=300)
    report = fit_learned_profile(babble, profile, options).learned.report  # type: ignore[union-attr]
    assert any(n.startswith("300 training faces recombined from ") for n in report.notes)
    assert sum(n.startswith("region ") for n in report.notes) == 2  # the two halves
    plain = fit_learned_profile(
        babble, profile, FitOptions(candidates=("poly_ridge",), recombined=0)
    )
    assert not any("recombined" in n for n in plain.learned.report.notes)  # type: ignore[union-attr]


def test_regions_babbled_together_are_recombined_together() -> None:
    from facesynth.app.learn.recombine import babbled_units

    u = np.array([[0.5, -0.2, 0, 0], [1, 1, 1, 1], [0, 0, 0.3, 0], [0, 0, 0, 0.0]])
    assert babbled_units(((0,), (1,), (2, 3)), u) == ((0, 1), (2, 3))  # row 0 joins 0 and 1
    assert babbled_units(((0,), (1,), (2, 3)), u[1:]) == ((0,), (1,), (2, 3))  # whole face
