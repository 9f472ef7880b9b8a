"""The self-model's face and Jacobian (facesynth.services.translator.self_model_face) and the
plan through it, against the computation they replaced (term by term, a Python loop over the
degree with np.delete and np.add.at, and a full-size solve with the fixed servos' columns
zeroed): random polynomials of degree 1 to 3, both the tensor's way and the terms' way, and
forward models that overflow or hold NaN."""

from __future__ import annotations

from itertools import combinations_with_replacement

import numpy as np
import pytest

from facesynth.runtime.profiles.learned import PolyRidge, pack, unpack
from facesynth.runtime.profiles.learned_predict import poly_factors, predictor
from facesynth.services.translator.self_model import DAMPING, SelfModelPlanner
from facesynth.services.translator.self_model_face import PolyFace


def _polynomial(
    degree: int, servos: int, features: int, seed: int, scale: float = 1.0
) -> PolyRidge:
    """A random polynomial: every term of degree 1..``degree`` over ``servos`` (a few left out),
    random coefficients and intercept."""
    rng = np.random.default_rng(seed)
    rows = [
        np.bincount(combo, minlength=servos)
        for d in range(1, degree + 1)
        for combo in _combinations(servos, d)
    ]
    powers = np.array(rows, dtype=np.float64)
    powers = powers[rng.permutation(len(powers))[: max(1, len(powers) - 2)]]
    coef = rng.normal(0.0, scale, (features, len(powers)))
    return PolyRidge(
        degree=degree,
        powers=pack(powers),
        coef=pack(coef),
        intercept=pack(rng.normal(0.0, 1.0, features)),
    )


def _combinations(n: int, d: int) -> list[tuple[int, ...]]:
    return list(combinations_with_replacement(range(n), d))


def _reference_face(forward: PolyRidge, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The face and Jacobian as SelfModelPlanner.face computed them before the tensor."""
    coef, intercept = unpack(forward.coef), unpack(forward.intercept)
    factors = poly_factors(forward)
    n_servos = unpack(forward.powers).shape[1]
    rows = np.arange(len(factors))
    values = np.append(u, 1.0)[factors]
    terms = values.prod(axis=1)
    d_terms = np.zeros((len(factors), n_servos + 1))
    for column in range(factors.shape[1]):
        others = np.delete(values, column, axis=1).prod(axis=1)
        np.add.at(d_terms, (rows, factors[:, column]), others)
    return coef @ terms + intercept, coef @ d_terms[:, :n_servos]


def _reference_plan(
    forward: PolyRidge,
    steps: int,
    prior: float,
    x: np.ndarray,
    u0: np.ndarray,
    weights: np.ndarray | None = None,
    fixed: np.ndarray | None = None,
) -> np.ndarray:
    """SelfModelPlanner.plan before: every servo in the solve, fixed ones' columns zeroed."""
    n_servos = unpack(forward.powers).shape[1]
    eye = np.eye(n_servos) * (prior + DAMPING)
    u = np.clip(u0, -1.0, 1.0)
    free = None if fixed is None else np.where(fixed, 0.0, 1.0)
    for _ in range(steps):
        with np.errstate(all="ignore"):
            face, jacobian = _reference_face(forward, u)
            if free is not None:
                jacobian = jacobian * free
            weighted = jacobian if weights is None else jacobian * weights[:, None]
            gradient = weighted.T @ (x - face) - prior * (u - u0)
            normal = weighted.T @ jacobian + eye
            if not (np.isfinite(gradient).all() and np.isfinite(normal).all()):
                break
            try:
                step = np.linalg.solve(normal, gradient)
            except np.linalg.LinAlgError:
                break
        if not np.isfinite(step).all():
            break
        u = np.clip(u + step, -1.0, 1.0)
    return u


CASES = [(1, 5, 7), (2, 4, 9), (2, 16, 53), (3, 4, 6), (3, 6, 11)]


@pytest.mark.parametrize(("degree", "servos", "features"), CASES)
def test_the_tensors_face_and_jacobian_are_the_terms_up_to_rounding(
    degree: int, servos: int, features: int
) -> None:
    forward = _polynomial(degree, servos, features, seed=degree * 100 + servos)
    model = PolyFace(forward)
    assert model.tensor is not None  # small enough: the tensor's way
    for u in np.random.default_rng(1).uniform(-1.2, 1.2, (5, servos)):
        face, jacobian = model.at(np.append(u, 1.0))
        want_face, want_jacobian = _reference_face(forward, u)
        assert jacobian.shape == (features, servos)
        np.testing.assert_allclose(face, want_face, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(jacobian, want_jacobian, rtol=1e-12, atol=1e-12)
        assert np.allclose(face, predictor(forward)(u[None, :])[0], rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize(("degree", "servos", "features"), CASES)
def test_the_terms_way_is_bit_identical_to_the_loop(
    degree: int, servos: int, features: int
) -> None:
    forward = _polynomial(degree, servos, features, seed=degree * 10 + servos)
    model = PolyFace(forward, max_cells=0)  # no tensor: the terms' way
    assert model.tensor is None
    for u in np.random.default_rng(2).uniform(-1.2, 1.2, (5, servos)):
        face, jacobian = model.at(np.append(u, 1.0))
        want_face, want_jacobian = _reference_face(forward, u)
        assert np.array_equal(face, want_face) and np.array_equal(jacobian, want_jacobian)


def test_a_tensor_beyond_the_cap_is_not_built() -> None:
    forward = _polynomial(3, 6, 11, seed=5)
    assert PolyFace(forward, max_cells=11 * 7**3).tensor is not None
    assert PolyFace(forward, max_cells=11 * 7**3 - 1).tensor is None


@pytest.mark.parametrize(("degree", "servos", "features"), CASES)
@pytest.mark.parametrize("fixing", [False, True])
@pytest.mark.parametrize("max_cells", [None, 0])
def test_the_plan_is_the_old_plan_up_to_rounding(
    degree: int, servos: int, features: int, fixing: bool, max_cells: int | None
) -> None:
    """Both ways (tensor, terms), with fixed servos (the model reordered, free ones first)."""
    forward = _polynomial(degree, servos, features, seed=7 + degree, scale=0.3)
    rng = np.random.default_rng(3)
    planner = SelfModelPlanner(forward, 6, 0.5)
    if max_cells is not None:
        planner.model = PolyFace(forward, max_cells=max_cells)
    fixed = (np.arange(servos) % 3 == 1) if fixing else None
    for _ in range(4):
        x = rng.normal(0.0, 1.0, features)
        u0 = rng.uniform(-1.3, 1.3, servos)  # some outside [-1, 1]: clipped, as before
        weights = rng.uniform(0.0, 1.0, features)
        planned = planner.plan(x, u0, weights, fixed)
        want = _reference_plan(forward, 6, 0.5, x, u0, weights, fixed)
        np.testing.assert_allclose(planned, want, rtol=0.0, atol=1e-9)  # 1e-6 µs of 1000
        if fixed is not None:
            assert np.array_equal(planned[fixed], np.clip(u0, -1.0, 1.0)[fixed])


def test_every_servo_fixed_is_the_clipped_guess() -> None:
    forward = _polynomial(2, 4, 9, seed=4)
    u0 = np.array([0.3, -1.5, 2.0, 0.0])
    planned = SelfModelPlanner(forward, 6, 0.5).plan(np.ones(9), u0, None, np.ones(4, dtype=bool))
    assert np.array_equal(planned, np.clip(u0, -1.0, 1.0))


@pytest.mark.parametrize("max_cells", [None, 0])
@pytest.mark.parametrize("spoil", ["nan", "inf", "huge"])
def test_a_self_model_that_is_not_finite_stops_where_the_old_plan_stopped(
    spoil: str, max_cells: int | None
) -> None:
    """A NaN or infinite coefficient (which a file cannot hold, but arithmetic can reach) and
    coefficients of 1e300 (which overflow in the products) end the plan at the last finite
    commands, the same ones as before."""
    forward = _polynomial(2, 4, 9, seed=6, scale=0.3)
    coef = unpack(forward.coef)
    coef[2, 3] = {"nan": np.nan, "inf": np.inf, "huge": 1e300}[spoil]
    if spoil == "huge":
        coef[4] *= 1e300
    spoiled = PolyRidge(
        degree=2, powers=forward.powers, coef=pack(coef), intercept=forward.intercept
    )
    planner = SelfModelPlanner(spoiled, 6, 0.5)
    if max_cells is not None:
        planner.model = PolyFace(spoiled, max_cells=max_cells)
    u0 = np.array([0.2, -0.4, 1.3, 0.5])
    with np.errstate(all="raise"):  # no warning leaks out
        planned = planner.plan(np.ones(9), u0)
    want = _reference_plan(spoiled, 6, 0.5, np.ones(9), u0)
    assert np.all(np.isfinite(planned)) and np.all(np.abs(planned) <= 1.0)
    assert np.array_equal(planned, want)


def test_face_gives_arrays_of_its_own() -> None:
    """A degree-1 model's Jacobian is the tensor itself: face() hands out a copy."""
    forward = _polynomial(1, 3, 4, seed=8)
    planner = SelfModelPlanner(forward, 0, 0.0)
    _, jacobian = planner.face(np.zeros(3))
    jacobian[:] = 99.0
    assert np.array_equal(planner.face(np.zeros(3))[1], _reference_face(forward, np.zeros(3))[1])
