"""A region-structured inverse model: each servo's command from the features its region moves.

The whole-face inverse model reads every input for every servo. On a robot whose head turns
(simhead18_neck), its own turns moved the gaze, lid and cheek readings while babbling, so the
model learned to read the neck from them too; a performer who looks aside or laughs without
turning then turns the robot's neck. A :class:`~facesynth.runtime.profiles.learned.Regional`
model gives each servo from the features its region moves (``Regions.reads``, from the sweeps,
:func:`~facesynth.app.learn.regions.regions_from_sweeps`: those it moves mainly, and those of
the servos that mainly move one of them too) and from nothing else: the neck reads head_yaw.

Measured, the regions the sweeps find by interaction (``Regions.groups``) are no use here: on
simhead18_neck one jittery reading moved by nearly every servo (head_roll) joins 17 of the 18
servos into one region. Hence a mask per servo, not a model per region.

A servo keeps its own model (:data:`FAMILY` on its region's features: :func:`own_predictions`)
where its held-out command error beats the best whole-face candidate's (by :data:`MARGIN`)
(:func:`kept`); the others (and every servo whose region is unknown: no sweeps, or none of its
features among the fit's inputs) share that candidate on the whole face (:func:`compose`,
:func:`fit_parts`). The fit compares the two by held-out command error and by what their
commands do on the face (:class:`Faces`). The board runs the result in numpy
(:func:`facesynth.runtime.profiles.learned_predict.predictor`), and T's plan through the
whole-face self-model leaves the regional servos alone (it would turn the neck again).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from facesynth.app.learn.models import FitOptions, fit_model, sklearn_predict
from facesynth.app.learn.regions import Regions
from facesynth.runtime.profiles.learned import Part, Regional

#: A part: (indices of the fit's inputs it reads, indices of the outputs it gives).
PartIndices = tuple[tuple[int, ...], tuple[int, ...]]

#: The family each servo's own model is fitted with: few inputs, few poses per servo.
FAMILY = "poly_ridge"
#: A servo keeps its own model when its held-out command error (effective, fraction of its
#: range) is at most the whole-face model's plus this: it must do better by 0.01 of range.
#: Measured (``bench robot --head simhead18_neck --head simhead16 --learn-poses 600``, 472
#: frames, 2026-11-27), lead ρ on the two heads and the neck's head_yaw ρ: -0.01 (neck_yaw
#: alone kept) 0.60 / 0.58, 0.87; 0 (7 servos) 0.53 / 0.55, 0.89; the whole-face inverse
#: 0.59 / 0.61, 0.55. Each servo kept leaves T's plan through the self-model (whose
#: refinement the rest of the face's likeness owes much to) for its region's features.
MARGIN = -0.01
#: … and the regional model is kept when its commands' faces (through the self-model) are at
#: most this much farther from the held-out faces than the whole-face model's (std).
FACE_MARGIN = 0.05


def servo_inputs(regions: Regions, inputs: list[str], outputs: list[str]) -> list[tuple[int, ...]]:
    """Per output (live servo name), the indices of ``inputs`` its own model reads
    (``Regions.reads``); empty where unknown: no sweeps, or none of them among ``inputs``."""
    at = {name: index for index, name in enumerate(inputs)}
    reads = dict(zip(regions.servos, regions.reads, strict=False))
    return [
        tuple(sorted(at[name] for name in reads.get(servo, ()) if name in at)) for servo in outputs
    ]


def compose(own: list[tuple[int, ...]], kept: np.ndarray, inputs: int) -> list[PartIndices]:
    """The parts of a regional model: the outputs not ``kept`` (bool per output) share one
    part reading every input; each kept output is a part of its own (``own`` inputs)."""
    parts: list[PartIndices] = []
    whole = tuple(int(i) for i in np.flatnonzero(~kept))
    if whole:
        parts.append((tuple(range(inputs)), whole))
    parts.extend((own[o], (int(o),)) for o in np.flatnonzero(kept))
    return parts


class RegionalFitted:
    """The scikit-learn models of a regional candidate, predicting as the exported one does
    (``predict``: (n, inputs) → (n, outputs))."""

    def __init__(self, parts: list[tuple[PartIndices, Any]], outputs: int) -> None:
        self.parts = parts
        self.outputs = outputs

    def predict(self, x: np.ndarray) -> np.ndarray:
        out = np.empty((len(x), self.outputs))
        for (columns, members), fitted in self.parts:
            out[:, list(members)] = sklearn_predict(fitted, x[:, list(columns)])
        return out


def fit_parts(
    parts: list[PartIndices],
    whole: tuple[str, FitOptions],
    x: np.ndarray,
    y: np.ndarray,
    options: FitOptions,
) -> tuple[RegionalFitted, Regional]:
    """The regional model of ``parts`` fitted on ``x`` (n, inputs) → ``y`` (n, outputs): a
    part reading every input with the ``whole`` family (name, options), the servos' own
    parts with :data:`FAMILY`; the scikit-learn models (one :class:`RegionalFitted`) and the
    exported model."""
    fitted_parts = []
    exported = []
    for columns, members in parts:
        name, variant = whole if len(columns) == x.shape[1] else (FAMILY, options)
        fitted, model = fit_model(name, x[:, list(columns)], y[:, list(members)], variant)
        fitted_parts.append(((columns, members), fitted))
        exported.append(Part(inputs=list(columns), outputs=list(members), model=model))
    return RegionalFitted(fitted_parts, y.shape[1]), Regional(parts=exported)


def own_predictions(
    x: np.ndarray,
    y: np.ndarray,
    x_test: np.ndarray,
    own: list[tuple[int, ...]],
    options: FitOptions,
) -> np.ndarray:
    """(len(x_test), outputs): each output's own model (:data:`FAMILY` on its ``own``
    inputs, fitted on ``x`` → ``y``) on ``x_test``; NaN for outputs without own inputs."""
    out = np.full((len(x_test), y.shape[1]), np.nan)
    for output, columns in enumerate(own):
        if columns:
            fitted, _ = fit_model(FAMILY, x[:, list(columns)], y[:, [output]], options)
            out[:, output] = sklearn_predict(fitted, x_test[:, list(columns)])[:, 0]
    return out


def kept(own_error: np.ndarray, whole_error: np.ndarray, own: list[tuple[int, ...]]) -> np.ndarray:
    """Per output: whether its own model is kept (it has one, and its held-out error is at
    most the whole-face model's plus :data:`MARGIN`)."""
    has = np.array([bool(columns) for columns in own], dtype=bool)
    out: np.ndarray = has & (np.nan_to_num(own_error, nan=np.inf) <= whole_error + MARGIN)
    return out


class Faces:
    """What each candidate's commands do on the face: the held-out faces ``x`` (standardized)
    against the faces a self-model (``forward``: scikit-learn, commands → standardized
    inputs, fitted on the training poses) predicts for the candidate's commands, clipped into
    the responsive ranges ``low`` .. ``high``; the mean absolute difference, in standard
    deviations of the inputs."""

    def __init__(self, forward: Any, x: np.ndarray, low: np.ndarray, high: np.ndarray) -> None:
        self.forward, self.x, self.low, self.high = forward, x, low, high
        self.errors: dict[str, float] = {}

    def add(self, label: str, predicted: np.ndarray) -> None:
        """Candidate ``label``'s commands for the held-out faces."""
        made = sklearn_predict(self.forward, np.clip(predicted, self.low, self.high))
        self.errors[label] = float(np.abs(made - self.x).mean())

    def notes(self) -> list[str]:
        """A line for the fit's report: each candidate's face error."""
        if not self.errors:
            return []
        shown = ", ".join(f"{label} {error:.3f}" for label, error in self.errors.items())
        return [f"held-out face error (std, through the self-model): {shown}"]


def regional_notes(
    outputs: list[str], own: list[tuple[int, ...]], keep: np.ndarray, best: str
) -> list[str]:
    """Lines for the fit's report: which servos read their region alone, or why none does."""
    if not any(own):
        return ["regional inverse: not compared (no servo's region known from the sweeps)"]
    if not best.startswith("regional "):
        count = int(keep.sum())
        return [f"regional inverse not kept ({count} servos would read their region alone)"]
    alone = ", ".join(f"{outputs[o]} ({len(own[o])})" for o in np.flatnonzero(keep))
    return [f"regional inverse kept: these servos read their region's features alone: {alone}"]
