"""Planning through the robot's self-model: the command whose predicted face is nearest the
target face (Eva 2.0's use of a self-model, Faraj et al. 2021), in plain numpy.

The inverse model of a learned profile maps a face to commands; it was fitted on faces the
robot made itself, so a performer's face it could never make (an expression its actuators
cannot combine, features moving together in another way) lies outside what it has seen, where
a regression says little. The forward model (commands → face, the self-model) is the better
judge there: :class:`SelfModelPlanner` starts from the inverse model's guess ``u0`` and takes a
few damped Gauss-Newton steps on

    Σ w · (f(u) − x)² + prior · ‖u − u0‖²,   low ≤ u ≤ high

where ``f`` is the forward model (ridge on polynomial features), ``x`` the standardized target
face, ``w`` each feature's weight (1 unless given: :mod:`services.translator.retarget`), and
each step is projected onto the servos' bounds (their responsive range, a learned
profile's ``command_low`` .. ``command_high``; [-1, 1] by default). Where the target is
reachable the result is the command that makes it; where it is not, the reachable face nearest
to it (in the robot's own standardized units), rather than an extrapolation. A step the
forward model cannot compute in finite numbers (coefficients so large its arithmetic overflows)
ends the plan there.
"""

from __future__ import annotations

import numpy as np

from facesynth.runtime.profiles.learned import PolyRidge, unpack
from facesynth.runtime.profiles.learned_predict import poly_factors

#: Levenberg-Marquardt damping added to every step (standardized face units²).
DAMPING = 1e-3


class SelfModelPlanner:
    """Commands for target faces through a :class:`PolyRidge` forward model."""

    def __init__(
        self,
        forward: PolyRidge,
        steps: int,
        prior: float,
        low: np.ndarray | None = None,
        high: np.ndarray | None = None,
    ) -> None:
        """``low`` / ``high``: each servo's bounds (normalized; default -1 / +1), e.g. its
        responsive range."""
        self.coef = unpack(forward.coef)  # (inputs, terms)
        self.intercept = unpack(forward.intercept)
        self.n_servos = unpack(forward.powers).shape[1]
        # Each term as the servos it multiplies (index n_servos: the constant 1).
        self.factors = poly_factors(forward)
        self.degree = self.factors.shape[1]
        self.rows = np.arange(len(self.factors))
        self.steps, self.prior = steps, prior
        self.eye = np.eye(self.n_servos) * (prior + DAMPING)
        self.low = -np.ones(self.n_servos) if low is None else np.asarray(low, dtype=np.float64)
        self.high = np.ones(self.n_servos) if high is None else np.asarray(high, dtype=np.float64)

    def face(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The predicted standardized face for commands ``u`` (S,) and its Jacobian (F, S)."""
        values = np.append(u, 1.0)[self.factors]  # (T, degree)
        terms = values.prod(axis=1)
        d_terms = np.zeros((len(self.factors), self.n_servos + 1))
        for column in range(self.degree):
            others = np.delete(values, column, axis=1).prod(axis=1)
            np.add.at(d_terms, (self.rows, self.factors[:, column]), others)
        face: np.ndarray = self.coef @ terms + self.intercept
        jacobian: np.ndarray = self.coef @ d_terms[:, : self.n_servos]
        return face, jacobian

    def plan(
        self,
        x: np.ndarray,
        u0: np.ndarray,
        weights: np.ndarray | None = None,
        fixed: np.ndarray | None = None,
    ) -> np.ndarray:
        """Commands within the bounds for the standardized target face ``x``, from ``u0``;
        ``weights`` (one per face feature, >= 0; None: all 1) weigh each feature's squared
        error (0: the feature takes no part in the plan); ``fixed`` (one bool per servo; None:
        none) servos stay at ``u0`` (clipped), the others planned around them."""
        u = np.clip(u0, self.low, self.high)
        free = None if fixed is None else np.where(fixed, 0.0, 1.0)
        for _ in range(self.steps):
            step = self._step(x, u, u0, weights, free)
            if step is None:
                break  # the self-model overflows here (extreme coefficients): keep this plan
            u = np.clip(u + step, self.low, self.high)
        return u

    def _step(
        self,
        x: np.ndarray,
        u: np.ndarray,
        u0: np.ndarray,
        weights: np.ndarray | None = None,
        free: np.ndarray | None = None,
    ) -> np.ndarray | None:
        """One damped Gauss-Newton step from ``u`` (None: not computable in finite numbers);
        ``free``: 1 per servo the step may move, 0 per servo it leaves (None: all 1)."""
        with np.errstate(all="ignore"):
            face, jacobian = self.face(u)
            if free is not None:  # a fixed servo's column out: its step is 0
                jacobian = jacobian * free
            weighted = jacobian if weights is None else jacobian * weights[:, None]
            gradient = weighted.T @ (x - face) - self.prior * (u - u0)
            normal = weighted.T @ jacobian + self.eye
            if not (np.isfinite(gradient).all() and np.isfinite(normal).all()):
                return None
            try:
                step: np.ndarray = np.linalg.solve(normal, gradient)
            except np.linalg.LinAlgError:  # the damping lost among huge numbers: singular
                return None
        return step if np.isfinite(step).all() else None
