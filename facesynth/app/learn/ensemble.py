"""Where the self-model is least sure: the disagreement of an ensemble of self-models.

Pure numpy. :func:`disagreement` fits ``members`` self-models (ridge on degree-2 polynomial
terms of the normalized commands, predicting the standardized face), each on a seeded
bootstrap resample of the poses seen so far, and gives, for each candidate pose, how much
their predicted faces differ (the variance across members, averaged over the features). Poses
the data already pins down get the same prediction from every member; poses far from it, or
where the face turns, do not. :func:`least_sure` picks the candidates it disagrees on most:
the babbling plan spends its last poses there (query by committee).
"""

from __future__ import annotations

import numpy as np

#: Ridge penalty of each member: small, so a member follows its own resample (a strong
#: penalty pulls every member toward the same flat guess and hides the disagreement).
PENALTY = 1e-3


def _terms(u: np.ndarray) -> np.ndarray:
    """Degree-2 polynomial terms of ``u`` (n, S): the commands, then every product i <= j."""
    rows, cols = np.triu_indices(u.shape[1])
    out: np.ndarray = np.hstack([u, u[:, rows] * u[:, cols]])
    return out


def disagreement(
    u: np.ndarray, faces: np.ndarray, candidates: np.ndarray, members: int = 5, seed: int = 0
) -> np.ndarray:
    """Per row of ``candidates`` (m, S), the ensemble's disagreement on its face (>= 0); the
    members are fitted on ``u`` (n, S) → ``faces`` (n, d; rows with NaN are left out)."""
    keep = np.all(np.isfinite(faces), axis=1)
    u, faces = u[keep], faces[keep]
    if len(u) < 2:
        return np.zeros(len(candidates))
    scale = faces.std(axis=0)
    y = (faces - faces.mean(axis=0)) / np.where(scale > 0, scale, 1.0)
    x, xc = _terms(u), _terms(candidates)
    rng = np.random.default_rng(seed)
    predictions = []
    for _ in range(members):
        rows = rng.integers(0, len(x), len(x))
        xm, ym = x[rows], y[rows]
        mean_x, mean_y = xm.mean(axis=0), ym.mean(axis=0)
        a = xm - mean_x
        coef = np.linalg.solve(a.T @ a + PENALTY * np.eye(a.shape[1]), a.T @ (ym - mean_y))
        predictions.append((xc - mean_x) @ coef + mean_y)
    spread: np.ndarray = np.stack(predictions).var(axis=0).mean(axis=1)
    return spread


def least_sure(
    u: np.ndarray,
    faces: np.ndarray,
    candidates: np.ndarray,
    count: int,
    members: int = 5,
    seed: int = 0,
) -> np.ndarray:
    """Indices of the ``count`` candidates the ensemble disagrees on most, most first."""
    spread = disagreement(u, faces, candidates, members, seed)
    order: np.ndarray = np.argsort(-spread, kind="stable")[:count]
    return order
