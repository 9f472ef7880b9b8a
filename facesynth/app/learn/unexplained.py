"""What the robot's commands do not explain of each feature it saw while babbling.

A feature the camera reads on the robot's face moves for two reasons: the commands moved it, or
nothing the robot commands did (camera jitter, tracker hysteresis, a head pose read through the
skin of a head without a neck). :func:`unexplained` gives, per feature, the spread of the
second part: the residual of a self-model (commands → face) on poses it was not fitted on, by
``folds``-fold cross-validation over the poses (a pose babbled twice is in one fold), so every
sample counts once and a feature only jitter moves comes out at its whole spread. T leaves a
feature out of its plan when this is most of its spread (:mod:`services.translator.retarget`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

#: ``fit_predict(train_commands, train_faces, test_commands)``: the fitted self-model's faces.
FitPredict = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]


def unexplained(
    faces: np.ndarray,
    commands: np.ndarray,
    poses: np.ndarray,
    fit_predict: FitPredict,
    folds: int = 5,
) -> np.ndarray:
    """Per feature (a column of ``faces``, (n, d)), the standard deviation of the self-model's
    held-out residual; ``commands`` (n, S), ``poses`` (n,) each sample's pose index."""
    residual = np.zeros_like(faces)
    fold = np.asarray(poses) % folds
    for k in range(folds):
        out = fold == k
        if out.all() or not out.any():
            continue
        residual[out] = faces[out] - fit_predict(commands[~out], faces[~out], commands[out])
    spread: np.ndarray = residual.std(axis=0)
    return spread
