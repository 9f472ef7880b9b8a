"""The inverse and forward model families a learned profile is fitted with (scikit-learn), each
exported as the numpy model the board runs (:mod:`facesynth.runtime.profiles.learned`), and the
options of a fit (:class:`FitOptions`). :mod:`facesynth.app.learn.fit` compares them.

scikit-learn is imported here only, when a model is fitted (the ``learn`` extra).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from facesynth.runtime.profiles.learned_models import KNN, MLP, Base, Layer, PolyRidge, pack

#: The inverse models compared, by name.
CANDIDATES = ("poly_ridge", "knn", "mlp")
#: MLPs averaged per MLP candidate in ``facesynth learn``'s fit and ``learn.compare``
#: (``FitOptions.mlp_members``; 1 elsewhere, as before). On two heads, 620 poses, held-out
#: effective command error 0.101 -> 0.095 and 0.129 -> 0.121, for 4-5 times the MLPs' fitting
#: time (docs/learning.md, *Where the held-out command error is*).
MLP_MEMBERS = 5
#: From this many training samples on (a stream's frames: :mod:`facesynth.app.learn.stream`),
#: an MLP is trained by Adam for :data:`ADAM_EPOCHS` passes over mini-batches: on a 10-minute
#: stream (15,000 frames) L-BFGS's 1,000 full-batch iterations fitted 5 averaged MLPs in 523 s
#: (0.086 held out), Adam in 45 s (0.089; one MLP: 0.093; docs/learning.md).
ADAM_FROM = 2000
ADAM_EPOCHS = 200


class FitError(ValueError):
    """Babbling data from which no profile can be fitted."""


@dataclass(frozen=True)
class FitOptions:
    """How to fit (the defaults suit a few hundred to a few thousand poses)."""

    seed: int = 0
    held_out: float = 0.2
    min_present: float = 0.9
    min_std: float = 0.03
    dead_effect: float = 0.3
    candidates: tuple[str, ...] = CANDIDATES
    knn_k: int = 5
    mlp_layers: tuple[int, ...] = (64, 64)
    #: The MLP's L2 penalty (``fit_model``); the fit compares one MLP per ``mlp_alphas``.
    mlp_alpha: float = 0.1
    mlp_alphas: tuple[float, ...] = (0.1, 1.0)
    #: MLPs averaged per MLP candidate (seeded ``seed``, ``seed + 1``, …), exported as one
    #: MLP whose hidden layers hold the members side by side (:func:`side_by_side`): the
    #: board runs their mean in one pass. ``facesynth learn`` fits with :data:`MLP_MEMBERS`.
    mlp_members: int = 1
    #: T's planning through the forward model (``Learned.plan_steps``, ``plan_prior``). On
    #: simhead16 (600 poses babbled in real time; ``facesynth bench robot``), performer → robot
    #: mean ρ over the moved features: 0.44 with the inverse model alone, 0.49 with a prior of
    #: 0.02, 0.53-0.54 with priors of 0.5-5 (6 steps; 3 or 12 steps: no better). 4 steps
    #: since 2026-11-27: lead ρ / ratio / in reach over the whole video 0.59 / 0.54 / 0.68 on
    #: simhead16 and 0.20 / 0.52 / 0.68 on simhead16_stiff, against 0.59 / 0.50 / 0.67 and
    #: 0.20 / 0.53 / 0.67 with 6 (the steps do not converge: they alternate between two
    #: plans), for a third less of T's time (docs/learning.md).
    plan_steps: int = 4
    plan_prior: float = 1.0
    #: Fit even when some servos were not moved both ways (they stay at neutral).
    partial: bool = False
    #: Training faces recombined from poses that moved one region each
    #: (:mod:`facesynth.app.learn.augment`; 0: none), added to the inverse model's poses.
    #: Off by default: on the three simulated heads it did not lower the held-out error.
    recombined: int = 0
    #: Also compare each candidate as a regional model (one per region of the face, each
    #: servo from the features its region moves: :mod:`facesynth.app.learn.regional`).
    regional: bool = True


def require_sklearn() -> Any:
    """scikit-learn's modules used here, or a :class:`FitError` naming the extra."""
    try:
        from sklearn import linear_model, neighbors, neural_network, preprocessing
    except ImportError:
        raise FitError("fitting needs scikit-learn: pip install 'facesynth[learn]'") from None

    return linear_model, neighbors, neural_network, preprocessing


def poly_ridge(x: np.ndarray, y: np.ndarray, options: FitOptions) -> tuple[Any, PolyRidge]:
    linear_model, _, _, preprocessing = require_sklearn()
    poly = preprocessing.PolynomialFeatures(degree=2, include_bias=False).fit(x)
    ridge = linear_model.RidgeCV(alphas=np.logspace(-4, 2, 7), alpha_per_target=True)
    ridge.fit(poly.transform(x), y)
    coef = np.atleast_2d(ridge.coef_)
    model = PolyRidge(
        degree=2,
        powers=pack(poly.powers_.astype(np.float64)),
        coef=pack(coef),
        intercept=pack(np.atleast_1d(ridge.intercept_)),
    )
    return (poly, ridge), model


def _knn(x: np.ndarray, y: np.ndarray, options: FitOptions) -> tuple[Any, KNN]:
    _, neighbors, _, _ = require_sklearn()
    k = min(options.knn_k, len(x))
    knn = neighbors.KNeighborsRegressor(n_neighbors=k, weights="distance", algorithm="brute")
    knn.fit(x, y)
    return knn, KNN(k=k, weights="distance", train_x=pack(x), train_y=pack(y))


def _one_mlp(x: np.ndarray, y: np.ndarray, options: FitOptions, seed: int) -> Any:
    _, _, neural_network, _ = require_sklearn()
    many = len(x) >= ADAM_FROM
    mlp = neural_network.MLPRegressor(
        hidden_layer_sizes=options.mlp_layers,
        activation="tanh",
        solver="adam" if many else "lbfgs",
        alpha=options.mlp_alpha,
        max_iter=ADAM_EPOCHS if many else 1000,
        random_state=seed,
    )
    with warnings.catch_warnings():  # an MLP stopping at max_iter is still a model
        warnings.simplefilter("ignore")
        mlp.fit(x, y)
    return mlp


class Averaged:
    """The mean prediction of fitted scikit-learn models (an MLP candidate's members)."""

    def __init__(self, members: list[Any]) -> None:
        self.members = members

    def predict(self, x: np.ndarray) -> np.ndarray:
        """The members' mean prediction."""
        out: np.ndarray = np.mean([m.predict(x) for m in self.members], axis=0)
        return out


def side_by_side(
    members: list[list[tuple[np.ndarray, np.ndarray]]],
) -> list[tuple[np.ndarray, np.ndarray]]:
    """One MLP giving the mean of ``members`` (each its layers' ``(weights (in, out), bias)``,
    all with the same layer sizes and activation): the first layer's weights side by side,
    the hidden ones block-diagonal (no member reads another's units), the last stacked and
    divided by their number, its bias their mean."""
    count = len(members)
    if count == 1:
        return members[0]
    layers = []
    for index in range(len(members[0])):
        weights = [member[index][0] for member in members]
        biases = [member[index][1] for member in members]
        if index == len(members[0]) - 1:
            layers.append((np.vstack(weights) / count, np.mean(biases, axis=0)))
            continue
        if index == 0:
            stacked = np.hstack(weights)
        else:
            stacked = np.zeros((sum(w.shape[0] for w in weights), sum(w.shape[1] for w in weights)))
            row = column = 0
            for w in weights:
                stacked[row : row + w.shape[0], column : column + w.shape[1]] = w
                row, column = row + w.shape[0], column + w.shape[1]
        layers.append((stacked, np.concatenate(biases)))
    return layers


def _mlp(x: np.ndarray, y: np.ndarray, options: FitOptions) -> tuple[Any, MLP]:
    fitted = [_one_mlp(x, y, options, options.seed + k) for k in range(max(options.mlp_members, 1))]
    layers = side_by_side([list(zip(m.coefs_, m.intercepts_, strict=True)) for m in fitted])
    model = MLP(
        activation="tanh",
        layers=[Layer(weights=pack(w), bias=pack(b)) for w, b in layers],
    )
    return (fitted[0] if len(fitted) == 1 else Averaged(fitted)), model


FITTERS: dict[str, Callable[[np.ndarray, np.ndarray, FitOptions], tuple[Any, Base]]] = {
    "poly_ridge": poly_ridge,
    "knn": _knn,
    "mlp": _mlp,
}


def sklearn_predict(fitted: Any, x: np.ndarray) -> np.ndarray:
    """scikit-learn's own prediction of a fitted candidate, (n, outputs)."""
    if isinstance(fitted, tuple):
        poly, ridge = fitted
        out = ridge.predict(poly.transform(x))
    else:
        out = fitted.predict(x)
    return np.asarray(out, dtype=np.float64).reshape(len(x), -1)


def candidate_variants(options: FitOptions) -> dict[str, tuple[str, FitOptions]]:
    """The candidates compared, by the name the report gives them: an MLP per penalty."""
    variants = {}
    for name in options.candidates:
        if name != "mlp":
            variants[name] = (name, options)
            continue
        for alpha in options.mlp_alphas or (options.mlp_alpha,):
            variants[f"mlp(alpha={alpha:g})"] = (name, replace(options, mlp_alpha=alpha))
    return variants


def fit_model(name: str, x: np.ndarray, y: np.ndarray, options: FitOptions) -> tuple[Any, Base]:
    """Fit candidate ``name`` on ``x`` → ``y``: (the scikit-learn model, the exported model)."""
    if name not in FITTERS:
        raise FitError(f"unknown model {name!r} (one of {', '.join(FITTERS)})")
    fitted, model = FITTERS[name](x, y, options)
    return fitted, model
