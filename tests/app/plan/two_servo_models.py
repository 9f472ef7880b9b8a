"""Two-servo self-models and a performance for the tests of the whole performance's commands
(tests/app/plan/test_sequence.py, test_sequence_rehearsed.py)."""

from __future__ import annotations

import numpy as np

from facesynth.runtime.profiles.learned import PolyRidge, pack
from facesynth.services.translator.self_model_face import PolyFace

#: Degree-2 terms of two servos (scikit-learn's PolynomialFeatures without the bias).
POWERS = np.array([[1, 0], [0, 1], [2, 0], [1, 1], [0, 2]], dtype=np.float64)
LOW, HIGH = -np.ones(2), np.ones(2)


def model(coef: list[list[float]]) -> PolyFace:
    """A self-model over two servos with these coefficients (features × the five terms)."""
    array = np.asarray(coef, dtype=np.float64)
    ridge = PolyRidge(
        degree=2, powers=pack(POWERS), coef=pack(array), intercept=pack(np.zeros(len(array)))
    )
    return PolyFace(ridge)


#: Two servos, three features; the third is moved by both servos at once.
COUPLED = model([[1, 0, 0, 0, 0], [0, 1, 0, 0, 0], [1, 1, 0, 0, 0]])
#: The robot as it is: curved where the self-model is straight.
TRUE = model([[1, 0, 0.6, 0, 0], [0, 1, 0, 0, -0.5], [1, 1, 0, 0.8, 0]])


def performance(frames: int = 80) -> np.ndarray:
    """Targets for the three features: the third moves against the sum of the first two."""
    t = np.linspace(0, 4 * np.pi, frames)
    a, b = np.sin(t), np.sin(t + 1.0)
    return np.c_[a, b, -0.3 * (a + b) + 0.8 * np.cos(2 * t)]


def least_squares(targets: np.ndarray) -> np.ndarray:
    """Frame by frame, the commands nearest each target through COUPLED (linear), clipped."""
    a = np.array([[1, 0], [0, 1], [1, 1]], dtype=np.float64)
    out: np.ndarray = np.clip(np.linalg.lstsq(a, targets.T, rcond=None)[0].T, LOW, HIGH)
    return out


def faces(head: PolyFace, u: np.ndarray) -> np.ndarray:
    return np.array([head.at(np.append(v, 1.0))[0] for v in u])
