"""The closed loop's correction through each servo's own region (services/translator/
closed_loop.py, ``regions``): a servo a regional inverse gives from its region's features is
corrected for the error of those features alone; a servo of the whole face, for all of it."""

from __future__ import annotations

import numpy as np
import pytest
from test_closed_loop import N_FEATURES, N_SERVOS, planner

from facesynth.services.translator.closed_loop import ClosedLoop, LoopOptions
from facesynth.services.translator.loop_regions import region_groups
from facesynth.services.translator.self_model import SelfModelPlanner

#: Servo 0 (a neck) reads feature 0 alone; servos 1 and 2 read the whole face.
REGIONS = np.ones((N_SERVOS, N_FEATURES), dtype=bool)
REGIONS[0] = [True, False, False, False]
U0 = np.array([0.1, -0.2, 0.3])


def seeing(model: SelfModelPlanner, options: LoopOptions, regions: np.ndarray | None) -> ClosedLoop:
    """A loop that has seen the face its self-model predicts for ``U0`` (nothing to refine)."""
    loop = ClosedLoop(model, model.low, model.high, options, regions=regions)
    face, _ = model.face(U0)
    loop.sent(U0, 0)
    loop.observe(face, 0)
    assert not loop.state.weights.any()
    return loop


def test_an_error_outside_a_servos_region_does_not_move_it() -> None:
    model = planner()
    face, _ = model.face(U0)
    x = face + np.array([0.0, 0.8, -0.5, 0.6])  # every feature off but the neck's own
    options = LoopOptions(damping=1.0, regional=True)
    whole = seeing(model, options, None).wanted(U0, x, None)
    regional = seeing(model, options, REGIONS).wanted(U0, x, None)
    assert abs(whole[0]) > 0.02  # the whole face's solve turns the neck for the others' error
    assert regional[0] == 0.0
    assert np.array_equal(regional[1:], whole[1:])  # the whole face's servos: as before
    assert np.abs(regional[1:]).max() > 0.02


def test_an_error_inside_its_region_moves_it_and_weights_still_count() -> None:
    model = planner()
    face, _ = model.face(U0)
    x = face + np.array([0.5, 0.0, 0.0, 0.0])
    loop = seeing(model, LoopOptions(damping=1.0, regional=True), REGIONS)
    assert abs(loop.wanted(U0, x, None)[0]) > 0.02
    unweighted = np.array([0.0, 1.0, 1.0, 1.0])  # its only feature weighs nothing in the plan
    assert loop.wanted(U0, x, unweighted)[0] == 0.0


def test_off_by_default_or_every_servo_whole_it_is_the_one_whole_face_solve() -> None:
    model = planner()
    face, _ = model.face(U0)
    x = face + np.array([0.3, 0.8, -0.5, 0.6])
    whole = seeing(model, LoopOptions(damping=1.0), None).wanted(U0, x, None)
    off = seeing(model, LoopOptions(damping=1.0), REGIONS)  # off by default
    assert off.groups is None and np.array_equal(off.wanted(U0, x, None), whole)
    every = np.ones((N_SERVOS, N_FEATURES), dtype=bool)
    assert region_groups(every, N_SERVOS, N_FEATURES, True) is None
    assert LoopOptions().regional is False  # it lost lead ρ on simhead18_neck: docs/learning.md


def test_servos_of_one_region_share_one_solve() -> None:
    regions = np.array([[1, 0, 0, 0], [1, 1, 1, 1], [1, 0, 0, 0]], dtype=bool)
    groups = region_groups(regions, N_SERVOS, N_FEATURES, True)
    assert groups is not None
    masks, index = groups
    assert masks.shape == (2, N_FEATURES)
    assert index[0] == index[2] != index[1]
    assert masks[index[0]].tolist() == [1.0, 0.0, 0.0, 0.0]


def test_regions_of_another_shape_are_refused_in_one_line() -> None:
    model = planner()
    with pytest.raises(ValueError, match="regions of shape \\(3, 5\\) do not fit") as info:
        ClosedLoop(model, model.low, model.high, regions=np.ones((N_SERVOS, N_FEATURES + 1)))
    assert "\n" not in str(info.value)
