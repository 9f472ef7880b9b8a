"""A learned mapping's models run in plain numpy (the board side: no scikit-learn).

:func:`predictor` turns a valid :data:`~.learned.Model` into a function that gives what
scikit-learn's ``predict`` gives for the model it was exported from (tested against it).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .learned_models import KNN, MLP, Base, Model, Part, PolyRidge, Regional, unpack

#: The functions of ``ACTIVATION_NAMES`` (a test keeps the two in step).
ACTIVATIONS: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "relu": lambda x: np.maximum(x, 0.0),
    "tanh": np.tanh,
}

Predict = Callable[[np.ndarray], np.ndarray]


def poly_factors(model: PolyRidge) -> np.ndarray:
    """Each polynomial term as the inputs it multiplies, (terms, degree): left to right as
    PolynomialFeatures does, so ((x_i * x_j) * x_k) is bit-identical; index ``inputs`` (one
    past the last input) stands for a constant 1.0 where a term has fewer factors."""
    powers = unpack(model.powers).astype(np.intp)
    n_terms, n_in = powers.shape
    degree = max(int(powers.sum(axis=1).max(initial=0)), 1)
    factors = np.full((n_terms, degree), n_in, dtype=np.intp)
    for term, row in enumerate(powers):
        chosen = np.repeat(np.arange(n_in), row)
        factors[term, : len(chosen)] = chosen
    return factors


def _poly_ridge(model: PolyRidge) -> Predict:
    coef_t = np.ascontiguousarray(unpack(model.coef).T)
    intercept = unpack(model.intercept)
    factors = poly_factors(model)
    degree = factors.shape[1]

    def predict(x: np.ndarray) -> np.ndarray:
        extended = np.concatenate([x, np.ones((x.shape[0], 1))], axis=1)
        terms = extended[:, factors]  # (n, T, degree); times the constant 1.0 is exact
        product = terms[:, :, 0]
        for column in range(1, degree):
            product = product * terms[:, :, column]
        out: np.ndarray = product @ coef_t + intercept
        return out

    return predict


def _knn(model: KNN) -> Predict:
    train_x, train_y = unpack(model.train_x), unpack(model.train_y)
    k, by_distance = model.k, model.weights == "distance"

    def predict(x: np.ndarray) -> np.ndarray:
        d2 = (
            np.sum(x * x, axis=1)[:, None]
            - 2.0 * x @ train_x.T
            + np.sum(train_x * train_x, axis=1)[None, :]
        )
        d2 = np.maximum(d2, 0.0)
        nearest = np.argpartition(d2, k - 1, axis=1)[:, :k] if k < d2.shape[1] else None
        if nearest is None:
            nearest = np.broadcast_to(np.arange(d2.shape[1]), d2.shape)
        neighbours = train_y[nearest]  # (n, k, O)
        if not by_distance:
            mean: np.ndarray = neighbours.mean(axis=1)
            return mean
        dist = np.sqrt(np.take_along_axis(d2, nearest, axis=1))
        with np.errstate(divide="ignore"):
            weights = 1.0 / dist
        exact = dist == 0.0
        rows = exact.any(axis=1)
        weights[rows] = exact[rows].astype(np.float64)
        out: np.ndarray = (
            np.einsum("nk,nko->no", weights, neighbours) / weights.sum(axis=1)[:, None]
        )
        return out

    return predict


def _mlp(model: MLP) -> Predict:
    layers = [(unpack(layer.weights), unpack(layer.bias)) for layer in model.layers]
    activation = ACTIVATIONS[model.activation]

    def predict(x: np.ndarray) -> np.ndarray:
        for index, (weights, bias) in enumerate(layers):
            x = x @ weights + bias
            if index < len(layers) - 1:
                x = activation(x)
        return x

    return predict


def _fused(parts: list[Part]) -> tuple[np.ndarray, Predict]:
    """The :class:`PolyRidge` parts of a regional model as one evaluation: every part's terms
    over the whole input (a factor index -1 is the constant 1.0), their coefficients
    block-diagonal; (the outputs it gives, its function). One product and one matrix
    product for all of them, not a pass per part (14 parts: 0.37 ms a frame against 0.03)."""
    factors, blocks, intercepts, outputs = [], [], [], []
    degree = max(poly_factors(part.model).shape[1] for part in parts)  # type: ignore[arg-type]
    for part in parts:
        assert isinstance(part.model, PolyRidge)
        local = poly_factors(part.model)
        inputs = np.append(np.array(part.inputs, dtype=np.intp), -1)  # local constant → -1
        padded = np.full((len(local), degree), -1, dtype=np.intp)
        padded[:, : local.shape[1]] = inputs[local]
        factors.append(padded)
        blocks.append(unpack(part.model.coef).T)
        intercepts.append(unpack(part.model.intercept))
        outputs.extend(part.outputs)
    coef = np.zeros((sum(len(f) for f in factors), len(outputs)))
    row = column = 0
    for block in blocks:
        coef[row : row + block.shape[0], column : column + block.shape[1]] = block
        row, column = row + block.shape[0], column + block.shape[1]
    every = np.concatenate(factors)
    intercept = np.concatenate(intercepts)

    def predict(x: np.ndarray) -> np.ndarray:
        extended = np.concatenate([x, np.ones((x.shape[0], 1))], axis=1)
        terms = extended[:, every]  # (n, T, degree); -1 is the constant column
        product = terms[:, :, 0]
        for column in range(1, degree):
            product = product * terms[:, :, column]
        # A term that overflows (extreme but finite parameters) meets the other blocks' zeros:
        # every fused output is NaN then, and T holds those servos (as for any overflow).
        with np.errstate(invalid="ignore"):
            out: np.ndarray = product @ coef + intercept
        return out

    return np.array(outputs, dtype=np.intp), predict


def _regional(model: Regional) -> Predict:
    polys = [part for part in model.parts if isinstance(part.model, PolyRidge)]
    others = [
        (
            np.array(part.inputs, dtype=np.intp),
            np.array(part.outputs, dtype=np.intp),
            _base(part.model),
        )
        for part in model.parts
        if not isinstance(part.model, PolyRidge)
    ]
    fused = [_fused(polys)] if polys else []
    n_out = sum(len(part.outputs) for part in model.parts)

    def predict(x: np.ndarray) -> np.ndarray:
        out = np.empty((x.shape[0], n_out))
        for outputs, run in fused:
            out[:, outputs] = run(x)
        for inputs, outputs, run_part in others:
            out[:, outputs] = run_part(x[:, inputs])
        return out

    return predict


def predictor(model: Model) -> Predict:
    """A numpy function ``(n, inputs) -> (n, outputs)`` for a valid model."""
    if isinstance(model, Regional):
        return _regional(model)
    return _base(model)


def _base(model: Base) -> Predict:
    if isinstance(model, PolyRidge):
        return _poly_ridge(model)
    if isinstance(model, KNN):
        return _knn(model)
    return _mlp(model)


def region_outputs(model: Model, inputs: int, outputs: int) -> np.ndarray:
    """Per output of a valid model over ``inputs`` inputs: whether a :class:`Regional` model
    gives it from its region's inputs alone (fewer than every input)."""
    out = np.zeros(outputs, dtype=bool)
    if isinstance(model, Regional):
        for part in model.parts:
            if len(part.inputs) < inputs:
                out[part.outputs] = True
    return out


def region_inputs(model: Model, inputs: int, outputs: int) -> np.ndarray:
    """Per output of a valid model over ``inputs`` inputs, the inputs its region reads,
    (outputs, inputs) bools: a :class:`Regional` part's inputs for its outputs, every input
    for an output of a whole-face model (or of a part that reads them all)."""
    out = np.ones((outputs, inputs), dtype=bool)
    if isinstance(model, Regional):
        for part in model.parts:
            mask = np.zeros(inputs, dtype=bool)
            mask[part.inputs] = True
            out[part.outputs] = mask
    return out
