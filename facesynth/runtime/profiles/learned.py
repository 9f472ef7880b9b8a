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
pickled. Models are a tagged union (``kind``, :mod:`.learned_models`): :class:`PolyRidge`
(ridge regression on polynomial features), :class:`KNN` (k nearest neighbours), :class:`MLP`
(a small perceptron), and for the inverse :class:`Regional` (one of those per region of the
face, each reading the inputs its region moves).
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

from .learned_models import (
    ACTIVATION_NAMES,
    DTYPES,
    KNN,
    MLP,
    ArrayData,
    Layer,
    Model,
    Part,
    PolyRidge,
    Regional,
    array_problem,
    model_problems,
    pack,
    unpack,
)
from .learned_retarget import Retarget, showable

__all__ = [
    "ACTIVATION_NAMES",
    "DTYPES",
    "KNN",
    "MAX_PLAN_STEPS",
    "MLP",
    "ArrayData",
    "Layer",
    "Learned",
    "Model",
    "Part",
    "PolyRidge",
    "Regional",
    "Report",
    "Retarget",
    "array_problem",
    "command_range",
    "describe_learned",
    "learned_problems",
    "model_problems",
    "pack",
    "showable",
    "shown_inputs",
    "unpack",
]

#: The most planning steps a file may ask of T per frame (each costs about 30 µs).
MAX_PLAN_STEPS = 20


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
    if isinstance(learned.forward, Regional):
        problems.append("forward: a regional model is for the inverse only")
    elif learned.forward is not None:
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
        if not (math.isfinite(options.lead_s) and 0 <= options.lead_s <= 1):
            problems.append(f"retarget.lead_s {options.lead_s!r} is outside [0, 1]")
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
