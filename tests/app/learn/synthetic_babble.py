"""A synthetic robot face for fitting tests: 16 commands → 40 features, nonlinear, coupled,
offset and noisy, two dead channels, plus features the head never moves and missing values;
optionally one-sided (slack on one side) and saturating servos."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from facesynth.app.learn.dataset import BabbleSet
from facesynth.app.learn.plan import Plan
from facesynth.runtime.feature_names import BY_NAME, NAMES
from facesynth.runtime.profiles import Profile, load_profile

#: Servo indices of head16_hardware that move nothing.
DEAD = (5, 11)
#: The features the synthetic head moves, and some it never moves (head pose).
MOVED = tuple(n for n in NAMES if not n.startswith(("head_", "gaze_")))[:40]
STILL = ("head_yaw", "head_pitch", "head_roll")


def hardware() -> Profile:
    """The bundled hardware profile the synthetic head is wired like."""
    return load_profile("head16_hardware")


class SyntheticHead:
    """The face's features (relative to its neutral) for normalized commands, with noise."""

    def __init__(
        self,
        seed: int = 1,
        noise: float = 0.01,
        moved: tuple[str, ...] = MOVED,
        one_sided: dict[int, int] | None = None,
        saturation: dict[int, float] | None = None,
    ) -> None:
        """``one_sided``: servo → the one side (+1 or -1) on which it moves the face (a cable
        pulling skin; the other side is slack, and its rest is at neutral); ``saturation``:
        servo → the command (normalized, both sides) beyond which its face stops changing."""
        rng = np.random.default_rng(seed)
        self.moved = moved
        n_servos, n_features = 16, len(moved)
        self.span = np.array([BY_NAME[n].default_max - BY_NAME[n].default_min for n in moved])
        self.gain_up = rng.uniform(0.6, 1.4, n_servos)
        self.gain_down = rng.uniform(0.4, 1.2, n_servos)
        self.power = rng.uniform(0.7, 1.6, n_servos)
        self.offset = rng.uniform(-0.2, 0.2, n_servos)  # the rest pulse is off neutral
        weights = rng.normal(0.0, 0.12, (n_features, n_servos))  # coupling
        live = [s for s in range(n_servos) if s not in DEAD]
        for j in range(n_features):
            weights[j, live[j % len(live)]] = rng.choice([-1.0, 1.0]) * rng.uniform(0.7, 1.2)
        weights[:, list(DEAD)] = 0.0
        self.weights = weights
        self.quadratic = rng.normal(0.0, 0.25, n_features)
        self.sided = np.zeros(n_servos)
        self.limit = np.ones(n_servos)
        for servo, side in (one_sided or {}).items():
            self.sided[servo], self.offset[servo] = side, 0.0
        for servo, limit in (saturation or {}).items():
            self.limit[servo] = limit
        self.noise = noise
        self.rng = np.random.default_rng(seed + 1000)

    def _actuators(self, u: np.ndarray) -> np.ndarray:
        v = np.clip(np.clip(u, -self.limit, self.limit) + self.offset, -1.0, 1.0)
        curve = np.sign(v) * np.abs(v) ** self.power
        out = np.where(v >= 0, self.gain_up * curve, self.gain_down * curve)
        out = np.where(self.sided > 0, np.maximum(out, 0.0), out)
        result: np.ndarray = np.where(self.sided < 0, np.minimum(out, 0.0), out)
        return result

    def features(self, u: np.ndarray) -> np.ndarray:
        """(n, features) raw features for (n, 16) normalized commands, relative to u = 0."""
        a = self._actuators(u) - self._actuators(np.zeros((1, u.shape[1])))
        z = a @ self.weights.T
        z = np.tanh(0.8 * z + self.quadratic * z * z) / 2.0
        noise = self.rng.normal(0.0, self.noise, z.shape)
        return (z + noise) * self.span


def synthetic_babble(n: int = 1500, seed: int = 0, head: SyntheticHead | None = None) -> BabbleSet:
    """A babbling set: sweeps, random poses, a neutral every 25 poses; a few NaN."""
    head = head or SyntheticHead()
    profile = hardware()
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1.0, 1.0, (n, 16))
    kinds = ["random"] * n
    for i in range(0, n, 25):
        u[i], kinds[i] = 0.0, "neutral"
    sweeps = 16 * 4
    for s in range(16):
        for k, value in enumerate((-1.0, -0.5, 0.5, 1.0)):
            row = 1 + s * 4 + k
            if kinds[row] == "random" and row < min(n, sweeps + 1):
                u[row] = 0.0
                u[row, s] = value
                kinds[row] = "sweep"
    faces = np.concatenate([head.features(u), rng.normal(0.0, 0.02, (n, len(STILL)))], axis=1)
    faces[rng.integers(0, n, 12), rng.integers(0, len(head.moved), 12)] = np.nan  # lost values
    return babble_set(profile, u, head.moved + STILL, faces, kinds)


def planned_babble(poses: int, seed: int = 0) -> BabbleSet:
    """The first ``poses`` poses of the real plan (neutral, sweeps, then random poses) on the
    synthetic head: what a session stopped at ``poses`` holds."""
    profile, head = hardware(), SyntheticHead()
    plan = Plan(len(profile.servos))
    chosen = [plan.pose(i) for i in range(poses)]
    u = np.array([pose.u for pose in chosen])
    rng = np.random.default_rng(seed)
    faces = np.concatenate([head.features(u), rng.normal(0.0, 0.02, (poses, len(STILL)))], 1)
    return babble_set(profile, u, head.moved + STILL, faces, [pose.kind for pose in chosen])


def babble_set(
    profile: Profile,
    u: np.ndarray,
    inputs: Sequence[str],
    faces: np.ndarray,
    kinds: Sequence[str],
) -> BabbleSet:
    """A session's samples: normalized commands ``u`` (n, S) of ``profile``'s servos, as the
    pulses they stand for, with their ``faces`` over ``inputs`` and their ``kinds``."""
    neutral = np.array([s.neutral_us for s in profile.servos])
    up = np.array([s.max_us - s.neutral_us for s in profile.servos])
    down = np.array([s.neutral_us - s.min_us for s in profile.servos])
    return BabbleSet(
        servos=tuple(s.name for s in profile.servos),
        commands=neutral + np.where(u >= 0, u * up, u * down),
        inputs=tuple(inputs),
        faces=faces,
        kinds=tuple(kinds),
    )
