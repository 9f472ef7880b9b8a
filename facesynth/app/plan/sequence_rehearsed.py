"""The whole performance's commands rehearsed on the robot (issue 27): iterative learning
control around :func:`~facesynth.app.plan.sequence.sequence_commands`.

The self-model is wrong in places; the robot is not. :func:`rehearsed_commands` lets the robot
show the commands found so far (``look``: every frame's commands → the faces it showed), adds
what the self-model got wrong at each frame to its faces, searches again, and keeps the round
the robot showed best. ``likeness_budget``'s ``sequence`` stage rehearses on the simulated head
(:func:`sequence_faces`); ``facesynth plan --driver … --camera …`` on a robot through its camera
(:mod:`facesynth.app.plan.rehearsal`, :func:`~facesynth.app.plan.performance.plan_performance`).
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass

import numpy as np

from facesynth.app.plan.sequence import (
    AMPLITUDE,
    ITERATIONS,
    SMOOTH,
    Likeness,
    model_faces,
    sequence_commands,
)
from facesynth.app.plan.targets import standardized
from facesynth.runtime.profiles import Profile
from facesynth.runtime.profiles.learned import PolyRidge, command_range, unpack
from facesynth.services.translator.self_model_face import PolyFace

__all__ = [
    "DAMPING",
    "REHEARSALS",
    "ROUNDS",
    "Look",
    "Rehearsal",
    "correlation_shown",
    "missed",
    "rehearsed_commands",
    "sequence_faces",
]

#: Rehearsals of :func:`rehearsed_commands` (on simhead16, whole video: the true head's ρ
#: 0.70, 0.71, 0.75, 0.75, 0.75, 0.75 after rounds 1 to 6).
ROUNDS = 3
#: Rehearsals on a real robot after it shows the plan (``facesynth plan --rounds``), with
#: :data:`DAMPING`: through simhead16's camera (whole video, every 3rd frame posed) the rounds
#: showed 0.695 / 0.707 / 0.719 and 0.693 / 0.717 / 0.731; undamped, the second round gave back
#: (0.695 / 0.719 / 0.718, and 0.696 / 0.718 / 0.708) (docs/learning.md, "Rehearsed on the
#: robot").
REHEARSALS = 2
#: How much of what the self-model newly got wrong a rehearsal round after the first adds to
#: the corrections already made (iterative learning control's gain; 1: replace them): the
#: plan's rehearsal on a robot seen through a camera (see :data:`REHEARSALS`).
DAMPING = 0.5


@dataclass(frozen=True)
class Rehearsal:
    """The commands each rehearsal round tried (the first: the start), the objective on what
    the robot showed for each (``look``'s faces, see :func:`rehearsed_commands`) and the mean
    correlation with the targets over the frames it showed (:func:`correlation_shown`);
    ``best``: the round whose commands the robot showed best;
    ``stopped``: the rehearsal ended early (``look`` said so)."""

    commands: list[np.ndarray]
    shown: list[float]
    shown_rho: list[float]
    stopped: bool = False

    @property
    def best(self) -> np.ndarray:
        """The commands the robot showed best."""
        return self.commands[int(np.argmax(self.shown))]


#: What a rehearsal looks at: every frame's commands (frames × servos) → the robot's faces
#: (frames × features, standardized; a row of NaN: not looked at or not seen), or None: stop.
Look = Callable[[np.ndarray], np.ndarray | None]


def rehearsed_commands(
    model: PolyFace,
    look: Look,
    targets: np.ndarray,
    start: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    *,
    features: list[int] | None = None,
    rounds: int = ROUNDS,
    amplitude: float = AMPLITUDE,
    smooth: float = SMOOTH,
    iterations: int = ITERATIONS,
    before: np.ndarray | None = None,
    damping: float = 1.0,
) -> Rehearsal:
    """:func:`sequence_commands`, rehearsed on the robot ``rounds`` times: the robot shows the
    commands so far (``look``, a round at a time), and what the self-model got wrong at each
    frame is added to its faces for the next search (iterative learning control, the
    self-model's Jacobian kept). Where the robot showed no face (a frame not looked at, a face
    not seen), what the self-model got wrong is interpolated in time between the frames it
    did show (none shown: nothing added). The robot shows the last round's commands too, so
    every round is judged on what it showed, not on the self-model: a round that made it worse
    (the self-model's slopes wrong there) is not the one kept. After the first round each
    round's corrections move ``damping`` of the way from the last ones to what the self-model
    got wrong at the commands just shown (1: to it; less: a noisy look counts for less).
    ``look`` returning None stops the rehearsal: the rounds shown so far are returned (none:
    ``commands`` empty)."""
    if rounds < 1:
        raise ValueError(f"rounds must be at least 1 (got {rounds})")
    if not 0 < damping <= 1:
        raise ValueError(f"damping must be within (0, 1] (got {damping:g})")
    targets = np.asarray(targets, dtype=np.float64)
    columns = list(range(targets.shape[1])) if features is None else list(features)
    likeness = Likeness(targets, columns, amplitude, smooth, before)
    commands = np.asarray(start, dtype=np.float64)
    tried: list[np.ndarray] = []
    shown: list[float] = []
    shown_rho: list[float] = []
    offsets: np.ndarray | None = None
    for round_ in range(rounds + 1):
        seen = look(commands)
        if seen is None:
            return Rehearsal(tried, shown, shown_rho, stopped=True)
        shown_faces = np.asarray(seen, dtype=np.float64)[:, columns]
        predicted = model_faces(model, commands, columns)
        errors = missed(shown_faces - predicted)
        faces = predicted + errors
        tried.append(commands)
        shown.append(likeness.value(faces, commands))
        seen_rho = correlation_shown(targets[:, columns], shown_faces)
        shown_rho.append(likeness.mean_rho(faces) if np.isnan(seen_rho) else seen_rho)
        if round_ == rounds:
            break
        offsets = errors if offsets is None else offsets + damping * (errors - offsets)
        commands = sequence_commands(
            model,
            targets,
            commands,
            low,
            high,
            features=columns,
            amplitude=amplitude,
            smooth=smooth,
            iterations=iterations,
            offsets=offsets,
            before=before,
        ).commands
    return Rehearsal(tried, shown, shown_rho)


def correlation_shown(targets: np.ndarray, seen: np.ndarray) -> float:
    """The mean correlation per feature between ``targets`` and the faces the robot showed
    (``seen``, frames × the same features; rows with a NaN: not shown), over the frames it
    showed; NaN when it showed fewer than 3 or no feature moves in both."""
    rows = np.isfinite(seen).all(axis=1)
    if rows.sum() < 3:
        return float("nan")
    x = targets[rows] - targets[rows].mean(axis=0)
    y = seen[rows] - seen[rows].mean(axis=0)
    norms = np.sqrt(np.sum(x**2, axis=0) * np.sum(y**2, axis=0))
    moving = norms > 0
    if not moving.any():
        return float("nan")
    return float(np.mean(np.sum(x * y, axis=0)[moving] / norms[moving]))


def missed(errors: np.ndarray) -> np.ndarray:
    """What the self-model got wrong per frame (frames × features; NaN: not shown), with
    each feature's gaps filled by linear interpolation in time between the frames shown
    (before the first and after the last: the nearest; never shown: 0)."""
    filled = np.zeros_like(errors)
    frames = np.arange(len(errors))
    for j in range(errors.shape[1]):
        shown = np.isfinite(errors[:, j])
        if shown.any():
            filled[:, j] = np.interp(frames, frames[shown], errors[shown, j])
    return filled


def sequence_faces(
    profile: Profile,
    look: Callable[[np.ndarray], np.ndarray],
    wanted: Sequence[np.ndarray | None],
    planned: Sequence[np.ndarray],
    chosen: Collection[str],
    rounds: int = ROUNDS,
) -> list[np.ndarray | None]:
    """``likeness_budget``'s ``sequence`` stage: per performer frame, the robot's face
    (``look``: the learned outputs' commands → its inputs, raw; None where T has no target)
    at the rehearsed commands that follow T's targets ``wanted`` best over the ``chosen``
    inputs (those the targets move), from T's own commands ``planned``. ValueError without a
    ``poly_ridge`` self-model."""
    learned = profile.learned
    if learned is None or not isinstance(learned.forward, PolyRidge):
        raise ValueError(f"profile {profile.name} has no poly_ridge self-model to follow with")
    mean, scale = unpack(learned.input_mean), unpack(learned.input_scale)
    low, high = command_range(learned)
    frames, targets = standardized(learned, list(wanted))
    moving = np.ptp(targets, axis=0) > 0
    columns = [i for i, name in enumerate(learned.inputs) if name in chosen and moving[i]]
    rehearsed = rehearsed_commands(
        PolyFace(learned.forward),
        lambda commands: np.array([(look(u) - mean) / scale for u in commands]),
        targets,
        np.array([planned[i] for i in frames]),
        low,
        high,
        features=columns,
        rounds=rounds,
    )
    faces: list[np.ndarray | None] = [None] * len(wanted)
    for index, u in zip(frames, rehearsed.best, strict=True):
        faces[index] = look(u)  # looked at anew: the round was chosen on its own looks
    return faces
