"""The closed loop through the robot's own camera: the pure core, plain numpy (issue 27).

A learned profile's open loop (:mod:`facesynth.services.translator.learned`) gives, per frame,
a command ``u0`` for the standardized target face ``x``: the inverse model's guess refined
through the self-model ``f``. With the robot's camera watched by the same tracker and F, the
robot's observed face tells how far the real face is from what ``f`` predicted. Per frame:

* **Refinement** (:meth:`ClosedLoop.observe`): each observed face ``y`` is paired with the
  commands in effect when it was captured (:meth:`ClosedLoop.sent`, the translator's final,
  limited positions as normalized commands; with ``response_s``, their first-order response:
  actuators slew and skin lags, and a face seen while the commands move, paired with the
  commands sent, teaches the loop that the face is weaker than it is, so it overdrives it:
  on simhead16 ρ 0.53-0.60 without, 0.65 with 0.1 s), and the model's error ``y - f(u)`` is
  fitted by recursive least squares as an affine function of the commands,
  ``e(u) ≈ W · [1, u]``: a bias per feature (the skin drifted, the camera moved, the neutral
  shifted) and a linear correction of the self-model's slopes (an actuator weaker or stronger
  than while babbling). The refined self-model is ``g(u) = f(u) + W · [1, u]``. Why affine and
  not the forward model's whole last layer (its 153 polynomial terms for 16 servos): a
  performance moves the commands along a thin, correlated path, which excites 17 regressors
  well enough within seconds and 153 hardly ever; what the affine part cannot hold stays with
  the babbled model. The fit forgets (``forgetting`` per observation, seconds of memory at
  camera rate) so it follows the operating point; its covariance is bounded (each diagonal
  term at most its prior: ``prior`` for the bias, ``slope_prior`` for each slope; the matrix
  scaled as a whole) so directions a performance does not excite do not wind up.
  Each feature's error is bounded to :data:`MAX_ERROR` standardized units (a tracking glitch
  counts as a large error, not an arbitrary one); features missing from the observation leave
  their row as it was.
* **Correction** (:meth:`ClosedLoop.correct`): at ``u0``, the refined prediction
  ``g(u0)`` plus ``observation_gain`` times what ``g`` still misses of the latest observation
  (0 by default: on simhead16 it added amplitude and cost correlation) gives the face ``u0``
  is expected to make, ``ŷ``; damped least squares through ``g``'s Jacobian
  ``J`` gives the change ``Δ* = (JᵀWJ + damping·I)⁻¹ JᵀW (x - ŷ)`` toward the target (``W``:
  each feature's weight in the plan, 0 for features the robot cannot show), bounded to
  ``±max_correction`` per servo. **Regions**: each servo's column of ``J`` is kept on the
  features it owns in the babbled self-model at neutral alone (``region_share``, 0: the
  whole face; :mod:`~facesynth.services.translator.loop_regions`), so the blinks' error
  never turns the neck. With ``regional`` (off: it cost lead ρ on simhead18_neck) a servo a
  regional inverse gives from its region's features (``regions``) takes its share of a solve
  on the error of those features only (one solve per distinct region).
  With ``integral_gain``, the integral of the observed error (each face against the target
  of the frame that made it, ``delay_s`` earlier:
  :mod:`facesynth.services.translator.loop_integral`, bounded, leaking, no wind-up at a
  servo's end) is added to it. **Lead**: the face follows the commands with a response time
  (actuators slew, skin lags: on simhead16 the robot's face follows T's targets best 3 frames
  late), so ``lead_s`` times the rate of the planned commands ``u0 + Δ*`` is added, and the
  face shows each target nearer its frame: the open loop's
  :class:`~facesynth.services.translator.lead.PhaseLead` (the rate low-passed at 10 Hz,
  restarted after a gap and whenever the face is lost). The correction applied moves toward
  all of it by at most ``max_step`` per servo per frame, and ``u = clip(u0 + Δ, low, high)``:
  within the servo's responsive range. Motion limits, safety rules and clamping follow in the
  translator as for the open loop, so the loop never drives outside the profile's limits or speeds.
* **Face lost** (no observation, none with a face, or the latest older than ``max_age_s``):
  ``Δ* = 0``, so the correction returns to the open loop at ``max_step`` per frame (no jump).

Time is data: every call takes its instant (``t_ns``, ``now_ns``) on one clock, the one the
observed frames' capture times are on. Nothing waits for a frame: the latest observation is
used as it is, so the loop adds no latency of its own (its age is bounded by ``max_age_s``).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import msgspec
import numpy as np

from facesynth.services.translator.lead import PhaseLead
from facesynth.services.translator.loop_integral import IntegralAction
from facesynth.services.translator.loop_regions import owned_regions, region_groups
from facesynth.services.translator.self_model import SelfModelPlanner

__all__ = ["MAX_ERROR", "ClosedLoop", "LoopOptions", "LoopState"]

#: An observed feature's error against the refined model counts for at most this much
#: (standardized units: times the robot's own spread of it while babbling).
MAX_ERROR = 3.0
#: Commands remembered for pairing observations with (a few seconds at camera rate).
HISTORY = 128


class LoopOptions(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """How the closed loop corrects and learns (see the module's docstring); normalized
    command units (1: a servo's whole travel on one side) and standardized face units."""

    max_step: float = 0.2
    max_correction: float = 0.6
    damping: float = 10.0
    observation_gain: float = 0.0
    max_age_s: float = 0.25
    forgetting: float = 0.995
    prior: float = 1.0
    slope_prior: float = 0.1
    response_s: float = 0.1
    integral_gain: float = 0.0
    integral_leak: float = 0.98
    delay_s: float = 0.125
    lead_s: float = 0.08
    regional: bool = False
    region_share: float = 0.5

    def problems(self) -> list[str]:
        """What is wrong with these options (empty: nothing)."""
        bounds = {
            "max_step": (0.0, 2.0),
            "max_correction": (0.0, 2.0),
            "damping": (0.0, 1e6),
            "observation_gain": (-1e-12, 1.0),
            "max_age_s": (0.0, 60.0),
            "forgetting": (0.5, 1.0),
            "prior": (0.0, 1e6),
            "slope_prior": (-1e-12, 1e6),
            "response_s": (-1e-12, 10.0),
            "integral_gain": (-1e-12, 1.0),
            "integral_leak": (0.0, 1.0),
            "delay_s": (-1e-12, 10.0),
            "lead_s": (-1e-12, 1.0),
            "region_share": (-1e-12, 1.0),
        }
        out = []
        for name, (low, high) in bounds.items():
            value = getattr(self, name)
            if not (np.isfinite(value) and low < value <= high):
                out.append(f"{name} {value!r} is outside ({max(low, 0.0):g}, {high:g}]")
        return out


@dataclass
class LoopState:
    """What the loop has learned: ``weights`` (features, servos + 1), the affine correction
    of the self-model; ``covariance`` (servos + 1, servos + 1), its recursive least squares
    covariance; ``updates``: how many observations it has taken."""

    weights: np.ndarray
    covariance: np.ndarray
    updates: int = 0

    @classmethod
    def fresh(cls, n_features: int, n_servos: int, options: LoopOptions) -> LoopState:
        """Nothing learned yet: no correction, the covariance at its prior."""
        return cls(
            weights=np.zeros((n_features, n_servos + 1)),
            covariance=np.diag(prior_diagonal(options, n_servos)),
        )


def prior_diagonal(options: LoopOptions, n_servos: int) -> np.ndarray:
    """The covariance's prior (and bound) per regressor: the bias's, then each slope's."""
    return np.append(options.prior, np.full(n_servos, options.slope_prior))


class ClosedLoop:
    """A learned profile's commands corrected through the robot's observed face."""

    def __init__(
        self,
        planner: SelfModelPlanner,
        low: np.ndarray,
        high: np.ndarray,
        options: LoopOptions | None = None,
        state: LoopState | None = None,
        regions: np.ndarray | None = None,
    ) -> None:
        """``planner``: the profile's self-model; ``low`` / ``high``: each servo's responsive
        range (normalized); ``state``: what an earlier run learned (None: nothing yet);
        ``regions``: (servos, features) bools, the features each servo's correction reads
        (a regional inverse's regions; None: every servo the whole face)."""
        self.options = options if options is not None else LoopOptions()
        if problems := self.options.problems():
            raise ValueError("closed loop: " + "; ".join(problems))
        self.planner = planner
        self.low, self.high = np.asarray(low, dtype=np.float64), np.asarray(high, np.float64)
        n_servos = planner.n_servos
        n_features = len(planner.intercept)
        self.state = (
            state if state is not None else LoopState.fresh(n_features, n_servos, self.options)
        )
        if self.state.weights.shape != (
            n_features,
            n_servos + 1,
        ) or self.state.covariance.shape != (
            n_servos + 1,
            n_servos + 1,
        ):
            raise ValueError(
                f"closed loop: a state of shape {self.state.weights.shape} does not fit "
                f"{n_features} features and {n_servos} servos"
            )
        self.eye = np.eye(n_servos)
        self.damped = self.options.damping * self.eye
        self._v = np.ones(n_servos + 1)  # [u, 1]: the self-model's input, reused
        self._phi = np.ones(n_servos + 1)  # [1, u]: the refinement's regressors, reused
        self.groups = region_groups(regions, n_servos, n_features, self.options.regional)
        self.mask = self._mask()
        self.bound = np.maximum(prior_diagonal(self.options, n_servos), 1e-300)
        # (sent at, the commands' response then, the commands sent)
        self.history: deque[tuple[int, np.ndarray, np.ndarray]] = deque(maxlen=HISTORY)
        self.correction = np.zeros(n_servos)
        self.lead = PhaseLead(max(self.options.lead_s, 0.0))  # on u0 + Δ*, as the open loop's
        self.integral = IntegralAction(
            n_servos,
            gain=self.options.integral_gain,
            leak=self.options.integral_leak,
            delay_s=self.options.delay_s,
            bound=self.options.max_correction,
            max_error=MAX_ERROR,
        )
        self.face: np.ndarray | None = None  # the latest observed face (standardized)
        self.face_u: np.ndarray | None = None  # the commands that were out when it was seen
        self.face_ns: int | None = None

    def _mask(self) -> np.ndarray | None:
        """(features, servos) 0/1: the features each servo's correction reads, those it owns
        in the babbled self-model at neutral (``region_share``,
        :mod:`~facesynth.services.translator.loop_regions`); None: the whole face."""
        with np.errstate(all="ignore"):
            _, jacobian = self._babbled(np.zeros(self.planner.n_servos))
        if self.options.region_share <= 0 or not np.isfinite(jacobian).all():
            return None
        owned = owned_regions(jacobian, self.options.region_share)
        return None if owned.all() else owned.T.astype(np.float64)

    def reset(self) -> None:
        """Forget the frames (commands sent, the latest face, the correction), keep what was
        learned."""
        self.history.clear()
        self.integral.reset()
        self.lead.reset()
        self.correction = np.zeros_like(self.correction)
        self.face = self.face_u = self.face_ns = None

    def sent(self, u: np.ndarray, t_ns: int) -> None:
        """The commands ``u`` (normalized) went out at ``t_ns``."""
        u = np.array(u, dtype=np.float64)
        if self.history and t_ns < self.history[-1][0]:
            self.history.clear()  # the clock went back: what came before pairs with nothing
        response = self.commands_at(t_ns)
        self.history.append((t_ns, u if response is None else response, u))

    def commands_at(self, t_ns: int) -> np.ndarray | None:
        """The commands in effect at ``t_ns`` (None: none sent by then): those out then, or,
        with ``response_s``, their first-order response (the face follows the commands with
        that time constant: actuators slew and skin lags, so a face seen while the commands
        move is paired with where the actuators were, not where they were sent)."""
        tau_ns = self.options.response_s * 1e9
        for sent_ns, response, u in reversed(self.history):
            if sent_ns <= t_ns:
                if tau_ns <= 0:
                    return u
                share = 1.0 - math.exp(-(t_ns - sent_ns) / tau_ns)
                out: np.ndarray = response + share * (u - response)
                return out
        return None

    def _babbled(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The babbled self-model's face ``f(u)`` and its Jacobian (which may be a view into
        the model's own arrays: not to be written to), without copies."""
        v = self._v
        v[:-1] = u
        return self.planner.model.at(v)

    def model(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The refined self-model's face ``g(u)`` and its Jacobian (features, servos)."""
        face, jacobian = self._babbled(u)
        weights = self.state.weights
        out: np.ndarray = face + weights[:, 0] + weights[:, 1:] @ u
        return out, jacobian + weights[:, 1:]

    def observe(self, face: np.ndarray | None, t_ns: int) -> None:
        """The robot's face captured at ``t_ns`` (standardized, NaN: a feature missing; None:
        no face): paired with the commands then out, it refines the self-model."""
        if face is None or not np.isfinite(face).any():
            self.face = self.face_u = self.face_ns = None
            self.integral.drop()
            return
        u = self.commands_at(t_ns)
        if u is None or not np.isfinite(u).all():
            return  # no command to pair it with yet: not a face this loop can use
        face = np.asarray(face, dtype=np.float64)
        with np.errstate(all="ignore"):
            predicted, _ = self._babbled(u)
            if not np.isfinite(predicted).all():
                return  # the self-model overflows here: nothing to learn from it
            self._learn(u, face - predicted)
        self.face, self.face_u, self.face_ns = face, u, t_ns
        if self.integral.gain > 0:
            with np.errstate(all="ignore"):
                _, jacobian = self.model(u)
            options = self.options
            self.integral.update(face, t_ns, jacobian, options.damping, u, self.low, self.high)

    def _learn(self, u: np.ndarray, error: np.ndarray) -> None:
        """One recursive least squares step of ``error ≈ weights · [1, u]`` (floating-point
        errors ignored by the caller); a step that cannot be computed in finite numbers (a
        state loaded with extreme values) starts the fit afresh instead."""
        state, forgetting = self.state, self.options.forgetting
        phi = self._phi
        phi[1:] = u
        present = np.isfinite(error)
        p_phi = state.covariance @ phi
        gain = p_phi / (forgetting + phi @ p_phi)
        residual = np.minimum(np.maximum(error - state.weights @ phi, -MAX_ERROR), MAX_ERROR)
        if present.all():
            weights = state.weights + np.outer(residual, gain)
        else:
            weights = state.weights.copy()
            weights[present] += np.outer(residual[present], gain)
        covariance = (state.covariance - np.outer(gain, p_phi)) / forgetting
        covariance = (covariance + covariance.T) / 2.0
        # Bounded per regressor (a direction the performance does not excite would wind
        # up), scaled as a whole so that it stays a covariance (positive semi-definite).
        excess = float((covariance.diagonal() / self.bound).max())
        if excess > 1.0:
            covariance /= excess
        if not (np.isfinite(weights).all() and np.isfinite(covariance).all()):
            n_features, n_regressors = state.weights.shape
            self.state = LoopState.fresh(n_features, n_regressors - 1, self.options)
            return
        state.weights, state.covariance = weights, covariance
        state.updates += 1

    def lost(self, now_ns: int) -> bool:
        """Whether the robot's face is lost at ``now_ns``: none seen, or the latest older than
        ``max_age_s`` (or from the future of ``now_ns`` by as much: another clock)."""
        if self.face_ns is None:
            return True
        return abs(now_ns - self.face_ns) > self.options.max_age_s * 1e9

    def wanted(self, u0: np.ndarray, x: np.ndarray, weights: np.ndarray | None) -> np.ndarray:
        """The correction ``Δ*`` toward the standardized target ``x`` from ``u0`` (zeros
        where it cannot be computed in finite numbers); the latest face must be known."""
        assert self.face is not None and self.face_u is not None
        options = self.options
        with np.errstate(all="ignore"):
            expected, jacobian = self.model(u0)
            if options.observation_gain > 0:  # what the refined model still misses
                seen, _ = self.model(self.face_u)
                missed = np.clip(
                    np.where(np.isfinite(self.face), self.face - seen, 0.0), -MAX_ERROR, MAX_ERROR
                )
                expected = expected + options.observation_gain * missed
            error = x - expected
            if self.mask is not None:  # each servo through the features it owns alone
                jacobian = jacobian * self.mask
            weighted = (jacobian if weights is None else jacobian * weights[:, None]).T
            if self.groups is not None:  # per region: its features' error alone, all servos
                weighted = weighted[None] * self.groups[0][:, None, :]  # (regions, S, F)
            normal = weighted @ jacobian + self.damped
            gradient = weighted @ error
            # (a gradient that is not finite gives a step that is not finite: checked below)
            if not np.isfinite(normal).all():
                return np.zeros_like(u0)
            try:
                if self.groups is None:
                    step = np.linalg.solve(normal, gradient)
                else:
                    steps = np.linalg.solve(normal, gradient[..., None])[..., 0]
                    step = steps[self.groups[1], np.arange(len(u0))]
            except np.linalg.LinAlgError:
                return np.zeros_like(u0)
        if not np.isfinite(step).all():
            return np.zeros_like(u0)
        bound = options.max_correction
        bounded: np.ndarray = np.minimum(np.maximum(step, -bound), bound)  # np.clip's
        return bounded

    def correct(
        self, u0: np.ndarray, x: np.ndarray, weights: np.ndarray | None, now_ns: int
    ) -> np.ndarray:
        """The commands for the standardized target face ``x`` at ``now_ns``, from the open
        loop's ``u0``; ``weights``: each feature's weight (None: all 1). Within ``low`` ..
        ``high``; ``u0`` itself (clipped) while the face is lost and the correction is back
        to 0."""
        u0 = np.asarray(u0, dtype=np.float64)
        usable = np.isfinite(u0).all() and np.isfinite(x).all()
        if usable:
            self.integral.planned(x, weights, now_ns)
        if self.lost(now_ns) or not usable:
            target = np.zeros_like(self.correction)
            self.integral.drop()
            self.lead.reset()
        else:
            bound = self.options.max_correction
            target = self.wanted(u0, x, weights)
            if self.integral.gain > 0:
                target = target + self.integral.z
            planned = u0 + target
            led = target + self.lead(planned, now_ns) - planned
            target = np.minimum(np.maximum(led, -bound), bound)  # np.clip's, as below
        limit = self.options.max_step
        change = np.minimum(np.maximum(target - self.correction, -limit), limit)
        self.correction = self.correction + change
        out: np.ndarray = np.minimum(np.maximum(u0 + self.correction, self.low), self.high)
        return out
