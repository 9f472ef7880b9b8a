"""Where the self-model is least sure (facesynth.app.learn.ensemble): the ensemble's
disagreement is small where the poses seen pin the face down and large where they do not."""

from __future__ import annotations

import numpy as np

from facesynth.app.learn.ensemble import disagreement, least_sure


def _face(u: np.ndarray) -> np.ndarray:
    return np.column_stack([np.sin(2.0 * u[:, 0]) + u[:, 1], u[:, 1] ** 2, u[:, 2]])


def test_the_ensemble_picks_the_poses_far_from_what_it_has_seen() -> None:
    rng = np.random.default_rng(0)
    seen = rng.uniform(-1.0, 1.0, (80, 3))
    seen[:, 0] *= 0.3  # servo 0 only babbled near neutral
    faces = _face(seen) + rng.normal(0.0, 0.01, (80, 3))
    near = rng.uniform(-1.0, 1.0, (20, 3))
    near[:, 0] *= 0.3
    far = rng.uniform(-1.0, 1.0, (5, 3))
    far[:, 0] = np.where(far[:, 0] >= 0, 1.0, -1.0)  # servo 0 at an end it never reached
    candidates = np.vstack([near[:10], far, near[10:]])
    chosen = least_sure(seen, faces, candidates, 5)
    assert sorted(chosen.tolist()) == list(range(10, 15))
    spread = disagreement(seen, faces, candidates)
    assert spread[10:15].min() > 5 * np.median(spread[np.r_[0:10, 15:25]])


def test_the_choice_is_seeded_and_rows_with_missing_values_are_left_out() -> None:
    rng = np.random.default_rng(1)
    seen = rng.uniform(-1.0, 1.0, (50, 3))
    faces = _face(seen)
    faces[3, 1] = np.nan
    candidates = rng.uniform(-1.0, 1.0, (40, 3))
    first = least_sure(seen, faces, candidates, 8, seed=4)
    assert np.array_equal(first, least_sure(seen, faces, candidates, 8, seed=4))
    assert np.all(np.isfinite(disagreement(seen, faces, candidates)))
    assert np.all(disagreement(seen[:1], faces[:1], candidates) == 0.0)  # nothing to go on
