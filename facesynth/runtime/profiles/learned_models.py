"""The models of a learned mapping, as a file holds them, and their checks (plain numpy).

Models are a tagged union (``kind``): :class:`PolyRidge` (ridge regression on polynomial
features), :class:`KNN` (k nearest neighbours), :class:`MLP` (a small perceptron), and
:class:`Regional` (file version 3): one such model per region of the face, each reading only
the inputs its region moves and giving only its region's outputs. Arrays travel as
:class:`ArrayData` (little-endian float32/float64 bytes with a shape), never pickled.
:func:`model_problems` checks every size, shape and value of one;
:func:`.learned_predict.predictor` runs it.
"""

from __future__ import annotations

import math

import msgspec
import numpy as np

#: The activations an MLP may use (:mod:`.learned_predict` runs them).
ACTIVATION_NAMES = ("relu", "tanh")

#: The dtypes an array may have in a file.
DTYPES = ("<f4", "<f8")


class ArrayData(msgspec.Struct, forbid_unknown_fields=True):
    """A numeric array: dtype (``"<f4"`` or ``"<f8"``), shape, and its bytes (C order)."""

    dtype: str
    shape: list[int]
    data: bytes


class PolyRidge(msgspec.Struct, tag="poly_ridge", tag_field="kind", forbid_unknown_fields=True):
    """Ridge regression on polynomial features (scikit-learn's PolynomialFeatures + Ridge).

    ``powers`` (T, D): each term's power of each input (whole numbers, row sums <= degree);
    ``coef`` (O, T); ``intercept`` (O,). y = prod(x ** powers) @ coef.T + intercept.
    """

    degree: int
    powers: ArrayData
    coef: ArrayData
    intercept: ArrayData


class KNN(msgspec.Struct, tag="knn", tag_field="kind", forbid_unknown_fields=True):
    """k nearest neighbours (Euclidean) on the training set; ``weights`` ``"uniform"`` (mean)
    or ``"distance"`` (1 / distance, an exact match wins), as KNeighborsRegressor."""

    k: int
    weights: str
    train_x: ArrayData
    train_y: ArrayData


class Layer(msgspec.Struct, forbid_unknown_fields=True):
    """One dense layer: ``x @ weights + bias``; ``weights`` (in, out), ``bias`` (out,)."""

    weights: ArrayData
    bias: ArrayData


class MLP(msgspec.Struct, tag="mlp", tag_field="kind", forbid_unknown_fields=True):
    """A multilayer perceptron (MLPRegressor): ``activation`` (``"relu"`` or ``"tanh"``) after
    every layer but the last, which is linear."""

    activation: str
    layers: list[Layer]


#: The models a region of a :class:`Regional` model may use.
Base = PolyRidge | KNN | MLP


class Part(msgspec.Struct, forbid_unknown_fields=True):
    """One region of a :class:`Regional` model: ``model`` maps the mapping's inputs at
    indices ``inputs`` (in that order) to its outputs at indices ``outputs``."""

    inputs: list[int]
    outputs: list[int]
    model: Base


class Regional(msgspec.Struct, tag="regional", tag_field="kind", forbid_unknown_fields=True):
    """One model per region of the face (``facesynth.app.learn.regional``): every output is
    given by exactly one part, from that part's inputs only (a servo of the neck never reads
    the gaze). Inverse models only, from file version 3."""

    parts: list[Part]


Model = PolyRidge | KNN | MLP | Regional


def pack(array: np.ndarray, dtype: str = "<f8") -> ArrayData:
    """``array`` as :class:`ArrayData` (converted to ``dtype``)."""
    data = np.ascontiguousarray(array, dtype=np.dtype(dtype))
    return ArrayData(dtype=dtype, shape=list(data.shape), data=data.tobytes())


def array_problem(array: ArrayData) -> str | None:
    """What is wrong with ``array`` (None: nothing): dtype, shape, size, finite values."""
    if array.dtype not in DTYPES:
        return f"dtype {array.dtype!r} is not one of {', '.join(DTYPES)}"
    if any(n < 0 for n in array.shape) or len(array.shape) > 2:
        return f"shape {array.shape} is not a vector or a matrix"
    itemsize = np.dtype(array.dtype).itemsize
    expected = math.prod(array.shape) * itemsize
    if len(array.data) != expected:
        return f"holds {len(array.data)} bytes, shape {array.shape} needs {expected}"
    values = np.frombuffer(array.data, dtype=np.dtype(array.dtype))
    if not np.all(np.isfinite(values)):
        return "holds values that are not finite"
    return None


def unpack(array: ArrayData) -> np.ndarray:
    """The float64 numpy array of a valid :class:`ArrayData` (see :func:`array_problem`)."""
    values = np.frombuffer(array.data, dtype=np.dtype(array.dtype))
    return values.astype(np.float64).reshape(array.shape)


def _model_arrays(model: Base) -> dict[str, ArrayData]:
    if isinstance(model, PolyRidge):
        return {"powers": model.powers, "coef": model.coef, "intercept": model.intercept}
    if isinstance(model, KNN):
        return {"train_x": model.train_x, "train_y": model.train_y}
    arrays = {}
    for index, layer in enumerate(model.layers):
        arrays[f"layers[{index}].weights"] = layer.weights
        arrays[f"layers[{index}].bias"] = layer.bias
    return arrays


def _shape_problems(model: Base, n_in: int, n_out: int) -> list[str]:
    """Shape and value problems of a model whose arrays are valid."""
    if isinstance(model, PolyRidge):
        powers, coef = unpack(model.powers), unpack(model.coef)
        intercept = unpack(model.intercept)
        if powers.ndim != 2 or powers.shape[1] != n_in:
            return [f"powers shape {list(powers.shape)} is not (terms, {n_in})"]
        if not (1 <= model.degree <= 4):
            return [f"degree {model.degree} is outside 1..4"]
        if np.any(powers < 0) or np.any(powers != np.round(powers)):
            return ["powers must be whole numbers >= 0"]
        # Each power first: a sum of huge powers would overflow (to inf, with a warning).
        if np.any(powers > model.degree) or np.any(powers.sum(axis=1) > model.degree):
            return [f"a term's powers add up to more than the degree {model.degree}"]
        if coef.shape != (n_out, powers.shape[0]) or intercept.shape != (n_out,):
            return [
                f"coef {list(coef.shape)} / intercept {list(intercept.shape)} do not fit "
                f"{n_out} outputs of {powers.shape[0]} terms"
            ]
        return []
    if isinstance(model, KNN):
        x, y = unpack(model.train_x), unpack(model.train_y)
        if x.ndim != 2 or x.shape[1] != n_in or y.shape != (x.shape[0], n_out):
            return [
                f"train_x {list(x.shape)} / train_y {list(y.shape)} are not (n, {n_in}) / "
                f"(n, {n_out})"
            ]
        if not 1 <= model.k <= x.shape[0]:
            return [f"k {model.k} is outside 1..{x.shape[0]} (the training set)"]
        if model.weights not in ("uniform", "distance"):
            return [f"weights {model.weights!r} is not 'uniform' or 'distance'"]
        return []
    if model.activation not in ACTIVATION_NAMES:
        return [f"activation {model.activation!r} is not one of {', '.join(ACTIVATION_NAMES)}"]
    if not model.layers:
        return ["an MLP needs at least one layer"]
    width = n_in
    for index, layer in enumerate(model.layers):
        weights, bias = unpack(layer.weights), unpack(layer.bias)
        if weights.ndim != 2 or weights.shape[0] != width or bias.shape != (weights.shape[1],):
            return [
                f"layers[{index}]: weights {list(weights.shape)} / bias {list(bias.shape)} do "
                f"not follow {width} inputs"
            ]
        width = weights.shape[1]
    if width != n_out:
        return [f"the last layer gives {width} outputs, not {n_out}"]
    return []


def _indices_problem(name: str, indices: list[int], count: int) -> str | None:
    if not indices:
        return f"{name} is empty"
    if len(set(indices)) != len(indices) or not all(0 <= i < count for i in indices):
        return f"{name} {indices[:6]} are not distinct indices below {count}"
    return None


def _regional_problems(where: str, model: Regional, n_in: int, n_out: int) -> list[str]:
    if not model.parts:
        return [f"{where}: a regional model needs at least one part"]
    problems: list[str] = []
    given: list[int] = []
    for index, part in enumerate(model.parts):
        at = f"{where}.parts[{index}]"
        for name, indices, count in (
            ("inputs", part.inputs, n_in),
            ("outputs", part.outputs, n_out),
        ):
            problem = _indices_problem(name, indices, count)
            if problem is not None:
                problems.append(f"{at}: {problem}")
        if problems:
            return problems
        given.extend(part.outputs)
        problems.extend(
            model_problems(f"{at}.model", part.model, len(part.inputs), len(part.outputs))
        )
    if sorted(given) != list(range(n_out)):
        problems.append(f"{where}: the parts must give each of the {n_out} outputs once")
    return problems


def model_problems(where: str, model: Model, n_in: int, n_out: int) -> list[str]:
    """Every problem of ``model`` mapping ``n_in`` values to ``n_out``."""
    if isinstance(model, Regional):
        return _regional_problems(where, model, n_in, n_out)
    problems = []
    for name, array in _model_arrays(model).items():
        problem = array_problem(array)
        if problem is not None:
            problems.append(f"{where}.{name}: {problem}")
    if problems:
        return problems
    return [f"{where}: {p}" for p in _shape_problems(model, n_in, n_out)]
