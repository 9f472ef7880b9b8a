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

from facesynth.runtime.profiles.learned import PolyRidge
from facesynth.services.translator.self_model_face import PolyFace

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
        #: The forward model's face and Jacobian (:mod:`.self_model_face`).
        self.model = PolyFace(forward)
        self.intercept = self.model.intercept  # (the closed loop reads its feature count)
        self.n_servos = self.model.n_servos
        self.steps, self.prior = steps, prior
        self.eye = np.eye(self.n_servos) * (prior + DAMPING)
        self.low = -np.ones(self.n_servos) if low is None else np.asarray(low, dtype=np.float64)
        self.high = np.ones(self.n_servos) if high is None else np.asarray(high, dtype=np.float64)
        self._frees: dict[
            bytes, tuple[PolyFace, np.ndarray, int, np.ndarray, np.ndarray, np.ndarray]
        ] = {}

    def face(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The predicted standardized face for commands ``u`` (S,) and its Jacobian (F, S)."""
        face, jacobian = self.model.at(np.append(u, 1.0))
        return face, np.array(jacobian)  # its own array, not a view into the model's

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
        none) servos stay at ``u0`` (clipped), the others planned around them.

        Each step solves for the free servos only: a fixed servo's Jacobian column is out, so
        the damped normal equations split into the free servos' block and the fixed ones'
        (whose step is nought). The plan runs on the model with the free servos first
        (:meth:`.PolyFace.reordered`, kept per pattern), so they are a slice of ``v``. A normal
        matrix or a step that is not finite (the self-model overflows: extreme coefficients)
        ends the plan at the last finite commands; a gradient that is not finite gives a step
        that is not finite (the solve's substitutions carry it), so it needs no check of its
        own."""
        model, order, moving, eye, low, high = self._free(fixed)
        v = np.append(np.minimum(np.maximum(u0[order], low), high), 1.0)  # [u, 1], reordered
        free = slice(0, moving)
        start = u0[order[free]]
        bottom, top = low[free], high[free]
        column = None if weights is None else weights[:, None]
        with np.errstate(all="ignore"):
            for _ in range(self.steps):
                face, jacobian = model.at(v)
                jacobian = jacobian[:, free]
                weighted = jacobian if column is None else jacobian * column
                u = v[free]
                gradient = np.dot(weighted.T, x - face) - self.prior * (u - start)
                normal = np.dot(weighted.T, jacobian) + eye
                if not np.isfinite(normal).all():
                    break
                try:
                    step = np.linalg.solve(normal, gradient)
                except np.linalg.LinAlgError:  # the damping lost among huge numbers: singular
                    break
                if not np.isfinite(step).all():
                    break
                v[free] = np.minimum(np.maximum(u + step, bottom), top)  # np.clip's
        out = np.empty(self.n_servos)
        out[order] = v[: self.n_servos]
        return out

    def _free(
        self, fixed: np.ndarray | None
    ) -> tuple[PolyFace, np.ndarray, int, np.ndarray, np.ndarray, np.ndarray]:
        """For ``fixed``: the model with the free servos first, that order, how many are free,
        their damping, and the bounds in that order; kept per pattern (a profile plans with
        one: its regional outputs)."""
        key = b"" if fixed is None else np.asarray(fixed, dtype=bool).tobytes()
        known = self._frees.get(key)
        if known is None:
            held = np.zeros(self.n_servos, dtype=bool) if not key else np.asarray(fixed, bool)
            order = np.concatenate([np.flatnonzero(~held), np.flatnonzero(held)])
            moving = int(np.count_nonzero(~held))
            model = self.model if not held.any() else self.model.reordered(order)
            eye = self.eye[:moving, :moving]  # a multiple of the identity: any order
            known = (model, order, moving, eye, self.low[order], self.high[order])
            self._frees[key] = known
        return known
