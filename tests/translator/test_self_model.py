"""Planning through the self-model (facesynth.services.translator.self_model): the forward model's
Jacobian, reachable targets reached, unreachable ones brought to the nearest reachable face,
the prior, the servos' range; and T using it from a learned profile."""

from __future__ import annotations

import msgspec
import numpy as np
import pytest

from facesynth.app.learn.fit import FitOptions, fit_model
from facesynth.runtime.profiles import Learned, Profile, load_profile
from facesynth.runtime.profiles.learned import PolyRidge, Report, pack, unpack
from facesynth.runtime.profiles.learned_predict import predictor
from facesynth.services.translator.learned import LearnedTargets
from facesynth.services.translator.self_model import SelfModelPlanner

INPUTS = ["brow_raise_inner_right", "jaw_open", "lip_corner_pull_left"]

SERVOS, FACE = 4, 9


def _true_face(u: np.ndarray) -> np.ndarray:
    """A smooth, coupled, nonlinear face of 4 commands (9 standardized features)."""
    rng = np.random.default_rng(7)
    linear = rng.normal(0.0, 1.0, (FACE, SERVOS))
    quadratic = rng.normal(0.0, 0.3, (FACE, SERVOS))
    return np.atleast_2d(u) @ linear.T + (np.atleast_2d(u) ** 2) @ quadratic.T


@pytest.fixture(scope="module")
def forward() -> PolyRidge:
    u = np.random.default_rng(0).uniform(-1.0, 1.0, (400, SERVOS))
    _, model = fit_model("poly_ridge", u, _true_face(u), FitOptions())
    assert isinstance(model, PolyRidge)
    return model


def test_the_jacobian_is_the_forward_models_derivative(forward: PolyRidge) -> None:
    planner, predict = SelfModelPlanner(forward, 5, 0.0), predictor(forward)
    u = np.array([0.3, -0.6, 0.1, 0.8])
    face, jacobian = planner.face(u)
    assert np.allclose(face, predict(u[None, :])[0])
    h = 1e-6
    numeric = np.column_stack(
        [
            (predict((u + h * e)[None, :])[0] - predict((u - h * e)[None, :])[0]) / (2 * h)
            for e in np.eye(SERVOS)
        ]
    )
    assert np.allclose(jacobian, numeric, atol=1e-5)


def test_a_reachable_face_is_reached_from_a_poor_guess(forward: PolyRidge) -> None:
    planner = SelfModelPlanner(forward, 8, 0.0)
    wanted = np.array([0.5, -0.4, 0.2, -0.7])
    planned = planner.plan(_true_face(wanted)[0], np.zeros(SERVOS))
    assert np.abs(planned - wanted).max() < 0.05


def test_an_unreachable_face_gives_the_nearest_reachable_one(forward: PolyRidge) -> None:
    planner, predict = SelfModelPlanner(forward, 8, 0.0), predictor(forward)
    target = _true_face(np.array([3.0, -2.5, 0.0, 2.0]))[0]  # far beyond the servos' range
    guess = np.zeros(SERVOS)
    planned = planner.plan(target, guess)
    assert np.all(np.abs(planned) <= 1.0)
    grid = np.stack(np.meshgrid(*[np.linspace(-1, 1, 11)] * SERVOS), axis=-1).reshape(-1, SERVOS)
    best = np.linalg.norm(predict(grid) - target, axis=1).min()  # the nearest reachable face
    after = np.linalg.norm(predict(planned[None, :])[0] - target)
    assert after <= best * 1.05  # projected Gauss-Newton: within 5 % of the grid's best
    assert after < np.linalg.norm(predict(guess[None, :])[0] - target)


def test_the_prior_keeps_the_plan_near_the_guess(forward: PolyRidge) -> None:
    target = _true_face(np.array([0.6, 0.6, -0.6, 0.6]))[0]
    guess = np.zeros(SERVOS)
    free = SelfModelPlanner(forward, 6, 0.0).plan(target, guess)
    held = SelfModelPlanner(forward, 6, 1e4).plan(target, guess)
    assert np.abs(held).max() < 0.01 < np.abs(free).max()


def test_no_steps_is_the_guess(forward: PolyRidge) -> None:
    guess = np.array([0.2, -1.4, 0.0, 0.5])
    assert np.array_equal(
        SelfModelPlanner(forward, 0, 0.1).plan(np.zeros(FACE), guess), np.clip(guess, -1, 1)
    )


def test_a_forward_model_that_overflows_keeps_the_last_finite_plan(forward: PolyRidge) -> None:
    """Found by fuzzing: coefficients of 1e300 (finite, so a valid file) overflowed the
    Gauss-Newton step to NaN, which the plan returned; it stops at the last finite plan."""
    coef = unpack(forward.coef)
    coef[0] *= 1e300
    huge = msgspec.structs.replace(forward, coef=pack(coef))
    guess = np.array([0.2, -0.4, 0.1, 0.5])
    with np.errstate(all="raise"):  # no warning leaks out either
        planned = SelfModelPlanner(huge, 6, 0.02).plan(np.ones(FACE), guess)
    assert np.all(np.isfinite(planned)) and np.all(np.abs(planned) <= 1.0)


def _learned_profile(forward: PolyRidge | None, steps: int) -> Profile:
    """head16_hardware with a linear learned mapping from three inputs to its first servos."""
    hardware = load_profile("head16_hardware")
    names = [spec.name for spec in hardware.servos]
    n_in = len(INPUTS)
    coef = np.zeros((SERVOS, n_in))
    coef[np.arange(SERVOS), np.arange(SERVOS) % n_in] = 1.0
    learned = Learned(
        inputs=list(INPUTS),
        reach_low=pack(np.full(n_in, -0.05)),
        reach_high=pack(np.full(n_in, 0.1)),
        input_mean=pack(np.zeros(n_in)),
        input_scale=pack(np.full(n_in, 0.1)),
        outputs=names[:SERVOS],
        dead=names[SERVOS:],
        inverse=PolyRidge(
            degree=1, powers=pack(np.eye(n_in)), coef=pack(coef), intercept=pack(np.zeros(SERVOS))
        ),
        forward=forward,
        plan_steps=steps,
        plan_prior=0.0,
        report=Report(model="poly_ridge", servo_error={}, candidates={}, samples=1, held_out=1),
    )
    return msgspec.structs.replace(hardware, learned=learned)


def test_t_plans_with_a_learned_profiles_self_model() -> None:
    # A forward model that is exactly linear (face = M u), so the plan can be checked.
    matrix = np.random.default_rng(3).normal(0.0, 1.0, (len(INPUTS), SERVOS))
    u = np.random.default_rng(4).uniform(-1, 1, (200, SERVOS))
    _, forward = fit_model("poly_ridge", u, u @ matrix.T, FitOptions())
    assert isinstance(forward, PolyRidge)
    planned = LearnedTargets(_learned_profile(forward, 6), {})
    plain = LearnedTargets(_learned_profile(forward, 0), {})
    assert planned.planner is not None and plain.planner is None
    t = np.array([0.05, 0.02, -0.03])
    x = (t - planned.mean) / planned.scale
    predict = predictor(forward)
    miss_planned = np.linalg.norm(predict(planned.commands(t)[None, :])[0] - x)
    miss_plain = np.linalg.norm(predict(plain.commands(t)[None, :])[0] - x)
    assert miss_planned < 0.5 * miss_plain


def test_the_plan_stays_within_the_given_bounds(forward: PolyRidge) -> None:
    """Bounds narrower than [-1, 1] (a learned profile's responsive range) hold every step."""
    low, high = np.array([-1.0, 0.0, -0.5, -1.0]), np.array([0.0, 1.0, 0.5, 1.0])
    planner = SelfModelPlanner(forward, 8, 0.0, low=low, high=high)
    target = _true_face(np.array([0.8, -0.8, 0.9, 0.3]))[0]  # outside the bounds
    planned = planner.plan(target, np.array([0.5, -0.5, 1.0, 0.0]))
    assert np.all(planned >= low) and np.all(planned <= high)
    inside = _true_face(np.array([-0.4, 0.3, 0.2, -0.6]))[0]  # inside: still reached
    reached = planner.plan(inside, np.zeros(SERVOS))
    assert np.abs(reached - np.array([-0.4, 0.3, 0.2, -0.6])).max() < 0.05
