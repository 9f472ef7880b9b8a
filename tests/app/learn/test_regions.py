"""The face's regions and symmetric pairs (facesynth.app.learn.regions), found from the sweeps
of a head whose coupling is known, and written into the learned file's report."""

from __future__ import annotations

import numpy as np
from synthetic_babble import hardware, synthetic_babble

from facesynth.app.learn.fit import FitOptions, fit_learned_profile
from facesynth.app.learn.regions import find_regions, sweep_effects, whole_face

SERVOS = ("right_lip_corner", "left_lip_corner", "jaw", "right_eyebrow", "left_eyebrow")
INPUTS = [
    "lip_corner_pull_right",
    "lip_corner_pull_left",
    "jaw_open",
    "brow_raise_outer_right",
    "brow_raise_outer_left",
]
#: Known coupling (features x servos): the lip corners each pull their own side, the jaw opens
#: the mouth and pulls both corners as strongly as they do (it interacts with them); the brows
#: each raise their own side, the left one also a little of the right (0.1: weak coupling).
WEIGHTS = np.array(
    [
        [1.0, 0.0, 0.8, 0.0, 0.0],
        [0.0, 1.0, 0.8, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 1.0, 0.1],
        [0.0, 0.0, 0.0, 0.0, 1.0],
    ]
)


def _sweeps(weights: np.ndarray, noise: float = 0.002) -> tuple[np.ndarray, ...]:
    """Neutral poses and each servo swept alone in 6 steps each way, on a linear head."""
    rng = np.random.default_rng(0)
    n_servos = weights.shape[1]
    rows = [np.zeros(n_servos) for _ in range(8)]
    kinds = ["neutral"] * 8
    for servo in range(n_servos):
        for level in (-1, -2 / 3, -1 / 3, 1 / 3, 2 / 3, 1):
            u = np.zeros(n_servos)
            u[servo] = level
            rows.append(u)
            kinds.append("sweep")
    u = np.array(rows)
    t = 0.1 * u @ weights.T + rng.normal(0.0, noise, (len(u), weights.shape[0]))
    return t, u, np.array(kinds)


def test_servos_that_move_one_feature_strongly_are_one_region_and_weak_coupling_is_not() -> None:
    t, u, kinds = _sweeps(WEIGHTS)
    effects = sweep_effects(t, u, kinds)
    assert effects is not None
    regions = find_regions(effects, SERVOS, INPUTS)
    assert regions.groups == ((0, 1, 2), (3,), (4,))
    assert regions.features[0] == ("lip_corner_pull_right", "lip_corner_pull_left", "jaw_open")
    assert regions.features[1:] == (("brow_raise_outer_right",), ("brow_raise_outer_left",))
    assert regions.pairs == (
        ("right_lip_corner", "left_lip_corner"),
        ("right_eyebrow", "left_eyebrow"),
    )
    notes = regions.notes()
    assert notes[0] == (
        "region 1: right_lip_corner, left_lip_corner, jaw move lip_corner_pull_right, "
        "lip_corner_pull_left, jaw_open"
    )
    assert (
        notes[-1] == "symmetric pairs: right_lip_corner/left_lip_corner, right_eyebrow/left_eyebrow"
    )


def test_a_stronger_coupling_joins_the_regions_and_a_dead_servo_is_no_pair() -> None:
    weights = WEIGHTS.copy()
    weights[3, 4] = 0.8  # the left brow now raises the right one nearly as much as its own
    weights[:, 1] = 0.0  # the left lip corner is dead
    weights[1, 2] = 0.0
    t, u, kinds = _sweeps(weights)
    effects = sweep_effects(t, u, kinds)
    assert effects is not None
    regions = find_regions(effects, SERVOS, INPUTS)
    assert regions.groups == ((0, 2), (1,), (3, 4))
    assert regions.features[1] == ()  # moves nothing
    assert regions.pairs == (("right_eyebrow", "left_eyebrow"),)


def test_without_neutral_poses_nothing_is_known() -> None:
    t, u, kinds = _sweeps(WEIGHTS)
    assert sweep_effects(t[8:], u[8:], kinds[8:]) is None
    assert whole_face(SERVOS).groups == ((0, 1, 2, 3, 4),)


def test_the_fit_writes_the_regions_and_pairs_into_the_report() -> None:
    learned = fit_learned_profile(
        synthetic_babble(400), hardware(), FitOptions(candidates=("poly_ridge",), recombined=0)
    ).learned
    assert learned is not None
    regions = [n for n in learned.report.notes if n.startswith("region ")]
    assert regions and all(" move " in n for n in regions)
    assert any(n.startswith("symmetric pairs: ") for n in learned.report.notes)
