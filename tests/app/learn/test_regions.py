"""The face's regions and symmetric pairs (facesynth.app.learn.regions), found from the sweeps
of a head whose coupling is known, and written into the learned file's report."""

from __future__ import annotations

import numpy as np
import pytest
from synthetic_babble import STILL, SyntheticHead, babble_set, hardware, synthetic_babble

from facesynth.app.learn.adaptive import AdaptiveOptions, AdaptivePlan
from facesynth.app.learn.dataset import BabbleSet
from facesynth.app.learn.fit import FitOptions, fit_learned_profile
from facesynth.app.learn.regions import (
    find_regions,
    regions_from_sweeps,
    sweep_effects,
    whole_face,
)

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


def _planned_session(lost: bool) -> tuple[AdaptivePlan, BabbleSet]:
    """The adaptive plan's sweeps and first region poses on the synthetic head, as the plan
    saw them and as a session records them; ``lost``: the first input is never seen at a
    neutral pose and every seventh face misses one value."""
    profile, head = hardware(), SyntheticHead(noise=0.002)
    servos = tuple(s.name for s in profile.servos)
    inputs = [*head.moved, *STILL]
    plan = AdaptivePlan(servos, inputs, AdaptiveOptions(region_poses=20, batch=5, candidates=20))
    rng = np.random.default_rng(3)
    rows, faces, kinds = [], [], []
    for index in range(plan.base.sweep_poses + 21):
        pose = plan.pose(index)
        u = np.array(pose.u)
        face = np.concatenate([head.features(u[None])[0], rng.normal(0.0, 0.02, len(STILL))])
        if lost and pose.kind == "neutral":
            face[0] = np.nan
        if lost and index % 7 == 3:
            face[rng.integers(1, len(inputs))] = np.nan
        plan.seen(pose, {name: v for name, v in zip(inputs, face, strict=True) if np.isfinite(v)})
        rows.append(u)
        faces.append(face)
        kinds.append(pose.kind)
    u = np.array(rows)
    babble = babble_set(profile, u, inputs, np.array(faces), kinds)
    return plan, babble


@pytest.mark.parametrize("lost", [False, True], ids=["seen", "nan faces"])
def test_the_plan_and_the_fit_find_the_same_regions_from_the_same_sweeps(lost: bool) -> None:
    plan, babble = _planned_session(lost)
    assert len(plan.regions.groups) >= 2  # the sweeps told the regions apart
    learned = fit_learned_profile(
        babble, hardware(), FitOptions(candidates=("poly_ridge",), regional=False)
    ).learned
    assert learned is not None
    fitted = [n for n in learned.report.notes if n.startswith(("region ", "symmetric pairs"))]
    assert fitted == plan.regions.notes()
    found = regions_from_sweeps(
        babble.faces,
        babble.normalized(hardware()),
        np.array(babble.kinds),
        babble.servos,
        list(babble.inputs),
    )
    assert found == plan.regions


def test_a_value_not_seen_is_no_evidence_and_does_not_hide_the_rest_of_the_face() -> None:
    t, u, kinds = _sweeps(WEIGHTS)
    effects = sweep_effects(t, u, kinds)
    lost = t.copy()
    lost[8::2, 1] = np.nan  # half the sweep faces miss the left lip corner
    lost[:8, 4] = np.nan  # the left brow's feature is never seen at neutral
    with_lost = sweep_effects(lost, u, kinds)
    assert effects is not None and with_lost is not None
    assert np.all(np.isfinite(with_lost))
    assert not with_lost[:, 4].any()  # no noise measured for it: no effect counted
    np.testing.assert_array_equal(with_lost[:, [0, 2, 3]], effects[:, [0, 2, 3]])
    assert with_lost[1, 1] == pytest.approx(effects[1, 1])  # its largest step was still seen
    regions = regions_from_sweeps(lost, u, kinds, SERVOS, INPUTS)
    assert regions.groups == ((0, 1, 2), (3,), (4,))
    assert regions.features[2] == ()  # the left brow moves nothing that was measured
    # one neutral, whatever offset the faces carry: raw or relative give the same effects
    np.testing.assert_allclose(sweep_effects(lost + 3.0, u, kinds), with_lost)  # type: ignore[arg-type]


def test_malformed_sweeps_are_a_clear_error() -> None:
    t, u, kinds = _sweeps(WEIGHTS)
    with pytest.raises(ValueError, match="do not pair up"):
        sweep_effects(t, u[:-1], kinds)
    with pytest.raises(ValueError, match="do not pair up"):
        sweep_effects(t, u, kinds[:-1])
    with pytest.raises(ValueError, match="are not over 4 inputs / 5 servos"):
        regions_from_sweeps(t, u, kinds, SERVOS, INPUTS[:4])
    with pytest.raises(ValueError, match="are not over 5 inputs / 4 servos"):
        regions_from_sweeps(t, u, kinds, SERVOS[:4], INPUTS)
    # no neutral poses, or sweeps that moved nothing: one region of every servo
    assert regions_from_sweeps(t[8:], u[8:], kinds[8:], SERVOS, INPUTS) == whole_face(SERVOS)
    assert regions_from_sweeps(0 * t, u, kinds, SERVOS, INPUTS) == whole_face(SERVOS)
