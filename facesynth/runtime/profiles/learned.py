"""A learned mapping: the face → servo-command model of a learned profile, in plain numpy.

A learned profile (``NAME.learned``, :mod:`.learned_file`) is a hardware profile (servos with
channels, limits and speeds, no sources) plus a :class:`Learned` mapping fitted on the robot's
own babbling (``facesynth learn``):

* ``inputs``: the feature names (keys of ``Features.raw``) the robot moved while babbling;
* ``reach_low`` / ``reach_high``: how far the robot's face moved each input, relative to its
  neutral (``reach_low <= 0 <= reach_high``, raw units);
* ``input_mean`` / ``input_scale``: the models see ``(t - input_mean) / input_scale``;
* ``outputs``: the live servos, in the inverse model's output order; ``dead``: servos whose
  command moved no input, kept at neutral;
* ``inverse``: standardized inputs → each output servo's normalized command ``u`` in [-1, 1]
  (0 neutral, +1 ``max_us``, -1 ``min_us``; *not* reversed-aware: the model learned the wiring,
  so ``reversed`` is ignored for a learned servo);
* ``forward``: ``u`` of the outputs → standardized inputs (the robot's self-model), or None;
* ``command_low`` / ``command_high``: each output's responsive range (optional; [-1, 1]);
* ``noise``: what the commands leave unexplained of each input (a self-model's held-out residual
  spread, :mod:`facesynth.app.learn.unexplained`; optional, from file version 2), and
  ``retarget``: how T retargets the performer's face into the robot's reach (optional; a file
  without it retargets as version 1 files did; :mod:`facesynth.services.translator.retarget`);
* ``report``: how the fit went (held-out command error per servo, as a fraction of its range).

Arrays travel as :class:`ArrayData` (little-endian float32/float64 bytes with a shape), never
pickled. Models are a tagged union (``kind``): :class:`PolyRidge` (ridge regression on
polynomial features), :class:`KNN` (k nearest neighbours), :class:`MLP` (a small perceptron).
:func:`.learned_predict.predictor` turns one into a numpy function that gives what
scikit-learn's ``predict`` gives for the model it was exported from; :func:`learned_problems`
checks every size, shape and value (the loader reports them as one
:class:`~.loading.ProfileError`).
"""

from __future__ import annotations

import math

import msgspec
import numpy as np

from facesynth.runtime.feature_names import NAMES

from .learned_retarget import Retarget, showable

#: The most planning steps a file may ask of T per frame (each costs about 30 µs).
MAX_PLAN_STEPS = 20

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


Model = PolyRidge | KNN | MLP


class Report(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """How the fit went. Errors are mean absolute command errors on held-out babbling poses,
    as a fraction of each servo's range (max_us - min_us).

    ``servo_error`` / ``candidates`` are the *raw* errors: the predicted command against the
    command babbled. ``effective_error`` / ``effective_candidates`` (empty in files fitted
    before them) are the *effective* errors: both commands first clipped into the servo's
    responsive range (``Learned.command_low`` .. ``command_high``), because two commands that
    give the same face are the same command to a camera. Issue 17's goal (held-out command
    error <= 0.05 of range) is measured against the effective error; the raw error is kept
    alongside (it counts travel that moves nothing, which no camera-based learner can learn).

    Every error covers the fitted servos (``Learned.outputs``) only. ``not_exercised`` lists
    the servos the babbling never moved and ``one_way`` those it moved to one side of neutral
    only (a fit of a session stopped before their sweeps, ``facesynth learn --partial``): both
    are kept at neutral with the dead ones (``Learned.dead``), but nothing is known of them.
    """

    model: str
    servo_error: dict[str, float]
    candidates: dict[str, float]
    samples: int
    held_out: int
    dropped: int = 0
    fit_seconds: float = 0.0
    created: str = ""
    notes: list[str] = []
    effective_error: dict[str, float] = {}
    effective_candidates: dict[str, float] = {}
    not_exercised: list[str] = []
    one_way: list[str] = []


class Learned(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """The learned mapping of a profile (see the module's docstring)."""

    inputs: list[str]
    reach_low: ArrayData
    reach_high: ArrayData
    input_mean: ArrayData
    input_scale: ArrayData
    outputs: list[str]
    dead: list[str]
    inverse: Model
    forward: Model | None = None
    #: Gauss-Newton steps through the forward model after the inverse model's guess (0: the
    #: inverse model alone; needs a ``poly_ridge`` forward model), and how strongly the plan
    #: stays near that guess (``facesynth.services.translator.self_model``).
    plan_steps: int = 0
    plan_prior: float = 0.02
    #: Each output's responsive range in normalized commands (``outputs``' order; None: the
    #: whole travel, [-1, 1]): the part of its travel over which the face still changes
    #: (``facesynth.app.learn.responsive``). T never commands a servo outside it.
    command_low: ArrayData | None = None
    command_high: ArrayData | None = None
    #: Each input's jitter at the robot's neutral (standard deviation over the neutral
    #: samples, raw units; None: unknown, every input counts as one the robot can show).
    noise: ArrayData | None = None
    retarget: Retarget | None = None
    report: Report


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


def _model_arrays(model: Model) -> dict[str, ArrayData]:
    if isinstance(model, PolyRidge):
        return {"powers": model.powers, "coef": model.coef, "intercept": model.intercept}
    if isinstance(model, KNN):
        return {"train_x": model.train_x, "train_y": model.train_y}
    arrays = {}
    for index, layer in enumerate(model.layers):
        arrays[f"layers[{index}].weights"] = layer.weights
        arrays[f"layers[{index}].bias"] = layer.bias
    return arrays


def _shape_problems(model: Model, n_in: int, n_out: int) -> list[str]:
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


def model_problems(where: str, model: Model, n_in: int, n_out: int) -> list[str]:
    """Every problem of ``model`` mapping ``n_in`` values to ``n_out``."""
    problems = []
    for name, array in _model_arrays(model).items():
        problem = array_problem(array)
        if problem is not None:
            problems.append(f"{where}.{name}: {problem}")
    if problems:
        return problems
    return [f"{where}: {p}" for p in _shape_problems(model, n_in, n_out)]


def learned_problems(learned: Learned, servos: list[str]) -> list[str]:
    """Every problem of a learned mapping for a profile with ``servos`` (empty: valid)."""
    problems: list[str] = []
    n_in = len(learned.inputs)
    if not n_in:
        problems.append("inputs is empty")
    unknown = [name for name in learned.inputs if name not in NAMES]
    if unknown:
        problems.append(f"inputs {unknown[:3]} are not features (facesynth.runtime.feature_names)")
    if len(set(learned.inputs)) != n_in:
        problems.append("inputs names a feature twice")
    for name in ("reach_low", "reach_high", "input_mean", "input_scale"):
        array = getattr(learned, name)
        problem = array_problem(array)
        if problem is None and array.shape != [n_in]:
            problem = f"shape {array.shape} is not [{n_in}] (one per input)"
        if problem is not None:
            problems.append(f"{name}: {problem}")
    if not problems:
        if np.any(unpack(learned.reach_low) > 0) or np.any(unpack(learned.reach_high) < 0):
            problems.append("needs reach_low <= 0 <= reach_high")
        if np.any(unpack(learned.input_scale) <= 0):
            problems.append("input_scale must be > 0")
    named = learned.outputs + learned.dead
    if len(set(named)) != len(named):
        problems.append("a servo is both in outputs and dead, or named twice")
    if sorted(named) != sorted(servos) and len(set(named)) == len(named):
        missing = sorted(set(servos) - set(named))
        extra = sorted(set(named) - set(servos))
        problems.append(
            f"outputs and dead must name each servo once (missing {missing}, unknown {extra})"
        )
    if not learned.outputs:
        problems.append("outputs is empty (no servo moved the face)")
    problems.extend(model_problems("inverse", learned.inverse, n_in, len(learned.outputs)))
    if learned.forward is not None:
        problems.extend(model_problems("forward", learned.forward, len(learned.outputs), n_in))
    if not 0 <= learned.plan_steps <= MAX_PLAN_STEPS:
        problems.append(f"plan_steps must be from 0 to {MAX_PLAN_STEPS}")
    if not (math.isfinite(learned.plan_prior) and learned.plan_prior >= 0):
        problems.append("plan_prior must be a finite number >= 0")
    if learned.plan_steps and not isinstance(learned.forward, PolyRidge):
        problems.append("plan_steps needs a poly_ridge forward model")
    problems.extend(_range_problems(learned))
    problems.extend(_retarget_problems(learned))
    return problems


def _retarget_problems(learned: Learned) -> list[str]:
    problems = []
    if learned.noise is not None:
        problem = array_problem(learned.noise)
        if problem is None and learned.noise.shape != [len(learned.inputs)]:
            problem = f"shape {learned.noise.shape} is not [{len(learned.inputs)}] (one per input)"
        if problem is None and np.any(unpack(learned.noise) < 0):
            problem = "must be >= 0"
        if problem is not None:
            problems.append(f"noise: {problem}")
    options = learned.retarget
    if options is not None:
        bounds = {
            "gain": (0.0, 2.0, options.gain),
            "tau_s": (0.0, 3600.0, options.tau_s),
            "min_weight": (0.0, 1.0, options.min_weight),
            "region_floor": (0.0, 1.0, options.region_floor),
        }
        for name, (low, high, value) in bounds.items():
            if not (math.isfinite(value) and low < value <= high):
                problems.append(f"retarget.{name} {value!r} is outside ({low:g}, {high:g}]")
        for name in ("show_noise", "extent"):
            value = getattr(options, name)
            if not (math.isfinite(value) and 0 <= value <= 100):
                problems.append(f"retarget.{name} {value!r} is outside [0, 100]")
    return problems


def _range_problems(learned: Learned) -> list[str]:
    n_out, problems = len(learned.outputs), []
    for name in ("command_low", "command_high"):
        array = getattr(learned, name)
        if array is None:
            continue
        problem = array_problem(array)
        if problem is None and array.shape != [n_out]:
            problem = f"shape {array.shape} is not [{n_out}] (one per output)"
        if problem is not None:
            problems.append(f"{name}: {problem}")
    if not problems:
        low, high = command_range(learned)
        if np.any(low < -1) or np.any(low > 0) or np.any(high < 0) or np.any(high > 1):
            problems.append("needs -1 <= command_low <= 0 <= command_high <= 1")
    return problems


def command_range(learned: Learned) -> tuple[np.ndarray, np.ndarray]:
    """Each output's responsive range ``(low, high)`` in normalized commands ([-1, 1] when
    the file has none); for a valid mapping."""
    n_out = len(learned.outputs)
    low = -np.ones(n_out) if learned.command_low is None else unpack(learned.command_low)
    high = np.ones(n_out) if learned.command_high is None else unpack(learned.command_high)
    return low, high


def shown_inputs(learned: Learned) -> list[str]:
    """The inputs of a valid mapping the robot can show (:func:`showable`; every input when
    the file has no ``retarget`` options)."""
    if learned.retarget is None:
        return list(learned.inputs)
    noise = None if learned.noise is None else unpack(learned.noise)
    mask = showable(unpack(learned.input_scale), noise, learned.retarget.show_noise)
    return [name for name, shown in zip(learned.inputs, mask, strict=True) if shown]


def describe_learned(learned: Learned) -> str:
    """One line about a learned mapping (for ``facesynth profile show``)."""
    report = learned.report
    live = [report.servo_error[n] for n in learned.outputs if n in report.servo_error]
    error = f", held-out error {np.mean(live):.3f} of range (worst {max(live):.3f})" if live else ""
    effective = [report.effective_error[n] for n in learned.outputs if n in report.effective_error]
    if effective:
        error += f", effective {np.mean(effective):.3f} (worst {max(effective):.3f})"
    unknown = len(report.not_exercised) + len(report.one_way)
    kept = f"{len(learned.dead) - unknown} dead" + (f", {unknown} not swept" if unknown else "")
    retarget = ""
    if learned.retarget is not None:
        shown = len(shown_inputs(learned))
        retarget = (
            f", retargets {learned.retarget.gain:g} of the performer's change into the robot's "
            f"reach over the {shown} inputs it can show"
        )
    return (
        f"learned: {report.model} from {len(learned.inputs)} inputs to {len(learned.outputs)} "
        f"servos ({kept}){error}, {report.samples} samples{retarget}"
    )
