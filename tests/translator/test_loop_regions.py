"""Which features each servo's closed-loop correction reads (services/translator/
loop_regions.py, ``LoopOptions.region_share``): each servo through the features it owns in the
babbled self-model, so an error a servo only touches (the blinks, for a neck) never moves it."""

from __future__ import annotations

import numpy as np
import pytest

from facesynth.runtime.profiles.learned import PolyRidge, pack
from facesynth.services.translator.closed_loop import ClosedLoop, LoopOptions
from facesynth.services.translator.loop_regions import owned_regions
from facesynth.services.translator.self_model import SelfModelPlanner

#: (features, servos): servo 0 (a neck) turns feature 0 (head_yaw) and moves feature 1 (a
#: blink, as the tracker reads it on a turned head) by a third of what servo 1 (a lid) does.
JACOBIAN = np.array(
    [
        [2.0, 0.0, 0.1],
        [0.5, 1.5, 0.0],
        [0.0, 0.3, 1.0],
        [0.2, 0.9, 0.8],
    ]
)
U0 = np.zeros(3)


def linear_planner() -> SelfModelPlanner:
    """A degree-1 self-model whose Jacobian is :data:`JACOBIAN` everywhere."""
    forward = PolyRidge(
        degree=1, powers=pack(np.eye(3)), coef=pack(JACOBIAN), intercept=pack(np.zeros(4))
    )
    return SelfModelPlanner(forward, 0, 0.0)


def seeing(options: LoopOptions) -> ClosedLoop:
    """A loop that has seen the face its self-model predicts at :data:`U0`."""
    model = linear_planner()
    loop = ClosedLoop(model, model.low, model.high, options)
    face, _ = model.face(U0)
    loop.sent(U0, 0)
    loop.observe(face, 0)
    return loop


def test_each_servo_owns_the_features_it_moves_most_or_nearly() -> None:
    owned = owned_regions(JACOBIAN, 0.5)
    assert owned.shape == (3, 4)
    assert owned[0].tolist() == [True, False, False, False]  # the blink is the lid's
    assert owned[1].tolist() == [False, True, False, True]
    assert owned[2].tolist() == [False, False, True, True]  # 0.8 >= half of 0.9
    assert owned_regions(JACOBIAN, 0.0).all()
    assert owned_regions(JACOBIAN, 1.0)[2].tolist() == [False, False, True, False]


def test_a_servo_moving_nothing_much_still_owns_its_largest_feature() -> None:
    jacobian = np.array([[2.0, 0.1], [1.0, 0.0]])  # servo 1 is beaten everywhere
    owned = owned_regions(jacobian, 0.5)
    assert owned[1].tolist() == [True, False]
    assert owned[0].tolist() == [True, True]


@pytest.mark.parametrize(
    ("jacobian", "share", "message"),
    [
        (JACOBIAN, 1.5, "region share 1.5 is outside"),
        (JACOBIAN, -0.1, "region share -0.1 is outside"),
        (np.array([[np.nan, 1.0]]), 0.5, "not finite"),
        (np.zeros((0, 2)), 0.5, "has no servos"),
    ],
)
def test_bad_shares_and_jacobians_are_refused_in_one_line(
    jacobian: np.ndarray, share: float, message: str
) -> None:
    with pytest.raises(ValueError, match=message) as info:
        owned_regions(jacobian, share)
    assert "\n" not in str(info.value)


def test_an_error_in_a_feature_the_neck_only_touches_does_not_turn_it() -> None:
    assert LoopOptions().region_share == 0.5  # the default: measured in docs/learning.md
    face, _ = linear_planner().face(U0)
    x = face + np.array([0.0, 0.8, 0.0, 0.0])  # only the blink is off
    owned = seeing(LoopOptions(damping=1.0)).wanted(U0, x, None)
    whole = seeing(LoopOptions(damping=1.0, region_share=0.0)).wanted(U0, x, None)
    assert abs(whole[0]) > 0.02  # over the whole face the neck turned for the blink
    assert owned[0] == 0.0
    assert owned[1] > 0.2  # the lid makes it


def test_an_error_in_the_necks_own_feature_still_turns_it() -> None:
    face, _ = linear_planner().face(U0)
    x = face + np.array([0.6, 0.0, 0.0, 0.0])
    step = seeing(LoopOptions(damping=1.0)).wanted(U0, x, None)
    assert step[0] > 0.2
    assert seeing(LoopOptions(region_share=0.7)).mask is not None
    assert seeing(LoopOptions(region_share=0.0)).mask is None


def test_a_self_model_that_overflows_at_neutral_leaves_the_whole_face() -> None:
    forward = PolyRidge(
        degree=1,
        powers=pack(np.eye(3)),
        coef=pack(np.full((4, 3), 1.0) * np.array([1.0, np.inf, 1.0])),
        intercept=pack(np.zeros(4)),
    )
    model = SelfModelPlanner(forward, 0, 0.0)
    loop = ClosedLoop(model, model.low, model.high, LoopOptions())
    assert loop.mask is None


def test_the_self_models_face_is_the_planners_bit_for_bit() -> None:
    loop = seeing(LoopOptions())
    u = np.array([0.3, -0.2, 0.7])
    face, jacobian = loop._babbled(u)
    expected_face, expected_jacobian = loop.planner.face(u)
    assert np.array_equal(face, expected_face)
    assert np.array_equal(jacobian, expected_jacobian)


def test_a_face_with_every_feature_learns_as_the_masked_update_would() -> None:
    """The refinement's step for a face with every feature (one outer product added) is the
    step for the same face through the update of a face with some missing, bit for bit."""
    loop = seeing(LoopOptions())
    state = loop.state
    weights, covariance = state.weights.copy(), state.covariance.copy()
    u = np.array([0.2, -0.4, 0.1])
    error = np.array([0.3, -0.1, 0.05, 0.2])
    loop._learn(u, error)
    phi = np.append(1.0, u)
    p_phi = covariance @ phi
    gain = p_phi / (loop.options.forgetting + phi @ p_phi)
    residual = np.clip(error - weights @ phi, -3.0, 3.0)
    reference = weights.copy()
    reference[np.isfinite(error)] += np.outer(residual, gain)
    assert np.array_equal(loop.state.weights, reference)
