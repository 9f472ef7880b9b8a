"""What the commands do not explain of each feature (facesynth/app/learn/unexplained.py): a
feature the commands move comes out near its noise, one only jitter moves at its whole spread."""

from __future__ import annotations

import numpy as np
import pytest

from facesynth.app.learn.unexplained import unexplained


def linear(train_u: np.ndarray, train_x: np.ndarray, test_u: np.ndarray) -> np.ndarray:
    """Least squares with an intercept: the self-model of a linear face."""
    design = np.column_stack([train_u, np.ones(len(train_u))])
    coef, *_ = np.linalg.lstsq(design, train_x, rcond=None)
    out: np.ndarray = np.column_stack([test_u, np.ones(len(test_u))]) @ coef
    return out


def test_moved_features_leave_their_noise_and_jitter_its_whole_spread() -> None:
    rng = np.random.default_rng(3)
    u = rng.uniform(-1.0, 1.0, (600, 2))
    moved = 0.5 * u[:, 0] - 0.2 * u[:, 1] + rng.normal(0.0, 0.01, 600)
    jitter = rng.normal(0.0, 0.3, 600)  # a head pose no command moves
    faces = np.column_stack([moved, jitter])
    spread = unexplained(faces, u, np.arange(600), linear)
    assert spread[0] == pytest.approx(0.01, rel=0.15)
    assert spread[1] / jitter.std() == pytest.approx(1.0, abs=0.05)


def test_a_pose_babbled_twice_stays_in_one_fold() -> None:
    """Held out pose by pose: a model that remembers its training poses (nearest pose) explains
    nothing of a pose it never saw, so a pure-jitter feature is not explained by repeats."""

    def nearest(train_u: np.ndarray, train_x: np.ndarray, test_u: np.ndarray) -> np.ndarray:
        index = np.abs(test_u[:, None, 0] - train_u[None, :, 0]).argmin(axis=1)
        out: np.ndarray = train_x[index]
        return out

    rng = np.random.default_rng(4)
    poses = np.repeat(np.arange(100), 2)  # each pose twice, its face the same both times
    u = rng.uniform(-1.0, 1.0, (100, 1))[poses]
    faces = rng.normal(0.0, 1.0, (100, 1))[poses]
    by_pose = unexplained(faces, u, poses, nearest)
    by_sample = unexplained(faces, u, np.arange(200), nearest)
    assert by_sample[0] < 0.2 < 1.0 < by_pose[0]  # split by sample, a repeat gives it away
