"""The commands that follow a whole performance best through a robot's self-model (issue 27).

T plans each frame on its own: the command whose predicted face is nearest that frame's target
(:mod:`facesynth.services.translator.self_model`). Likeness is measured otherwise: per feature,
the correlation between her face and the robot's over the performance (ρ, which no offset or
gain of a feature changes), and the robot's amplitude against hers. Where the robot cannot make
the target face, a frame-by-frame least-squares compromise may move one feature against her
to bring others closer, and ρ pays for it.

:func:`sequence_commands` asks the other question: knowing the whole performance, which
commands give the self-model's face the highest likeness? It maximizes, over every frame's
commands at once (within each servo's responsive range),

    mean over features j of  ρ(f_j, x_j) − amplitude · log²(std f_j / std x_j)
                             − smooth · mean over frames of ‖u_t − u_(t−1)‖²

where ``f_j`` is the self-model's face and ``x_j`` the target (T's retargeted face,
standardized as the models see it): the correlation, a penalty for showing her change at
another amplitude than the target asks, and one for jumps between frames. The gradient is
exact (ρ's derivative times the self-model's Jacobian), the search L-BFGS-B (SciPy, the
``learn`` extra's scikit-learn brings it).

Nothing in it is causal: a frame's command depends on frames still to come. It is a measure
of what the robot's face can show of this performance (``likeness_budget``'s ``sequence``
stage), not something T can do frame by frame; measured in docs/learning.md ("The ceiling is
the objective's").
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from facesynth.app.plan.targets import standardized
from facesynth.runtime.profiles import Profile
from facesynth.runtime.profiles.learned import PolyRidge, command_range, unpack
from facesynth.services.translator.self_model_face import PolyFace

__all__ = [
    "AMPLITUDE",
    "DAMPING",
    "REHEARSALS",
    "ROUNDS",
    "SMOOTH",
    "Followed",
    "Likeness",
    "Look",
    "Rehearsal",
    "correlation_shown",
    "likeness_gradient",
    "missed",
    "rehearsed_commands",
    "sequence_commands",
    "sequence_faces",
]

#: Weight of the amplitude term (log² of the robot's spread over the target's, per feature).
AMPLITUDE = 0.3
#: Weight of the jump term (mean squared change of the commands between frames).
SMOOTH = 0.5
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
#: The search's iterations at most (L-BFGS-B; the whole video's 472 frames stop by ~300).
ITERATIONS = 400


@dataclass(frozen=True)
class Followed:
    """The commands found (frames × servos), the objective's value at the start (T's commands
    or whatever was given) and at the end (through the self-model, with the offsets it was
    given), the search's iterations, and the mean correlation alone (the objective's first
    term) at the start and at the end."""

    commands: np.ndarray
    start_value: float
    value: float
    iterations: int
    start_rho: float = float("nan")
    rho: float = float("nan")


class Likeness:
    """The module's objective for fixed targets (frames × features, standardized) over some
    of their ``columns``, and its derivative by each frame's face and commands; with
    ``before`` (the commands held before the first frame, e.g. neutral), the jump into the
    first frame counts as the others do."""

    def __init__(
        self,
        targets: np.ndarray,
        columns: list[int],
        amplitude: float,
        smooth: float,
        before: np.ndarray | None = None,
    ) -> None:
        self.frames = len(targets)
        self.columns, self.amplitude, self.smooth = columns, amplitude, smooth
        self.before = before
        self.wanted = targets[:, columns] - targets[:, columns].mean(axis=0)
        self.wanted_norm = np.sqrt(np.sum(self.wanted**2, axis=0))
        self.wanted_std = self.wanted_norm / np.sqrt(self.frames)

    def mean_rho(self, faces: np.ndarray) -> float:
        """The mean correlation of ``faces`` (frames × the columns) with the targets."""
        shown = faces - faces.mean(axis=0)
        norm = np.sqrt(np.sum(shown**2, axis=0)) + 1e-12
        return float(np.mean(np.sum(shown * self.wanted, axis=0) / (norm * self.wanted_norm)))

    def value(self, faces: np.ndarray, u: np.ndarray) -> float:
        """The objective for ``faces`` (frames × the columns) shown at commands ``u``."""
        return self.gradient(faces, u)[0]

    def gradient(self, faces: np.ndarray, u: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        """The objective, its derivative by the faces (frames × columns) and, for the jump
        term, by the commands (frames × servos)."""
        shown = faces - faces.mean(axis=0)
        norm = np.sqrt(np.sum(shown**2, axis=0)) + 1e-12
        rho = np.sum(shown * self.wanted, axis=0) / (norm * self.wanted_norm)
        # dρ/df: the target's direction less ρ times the face's own (sums to 0 over frames)
        slope = self.wanted / (norm * self.wanted_norm) - rho * shown / norm**2
        log_ratio = np.log(norm / np.sqrt(self.frames) / self.wanted_std)
        slope -= self.amplitude * 2.0 * log_ratio * shown / norm**2
        count = len(self.columns)
        value = float(np.sum(rho - self.amplitude * log_ratio**2)) / count
        jumps = np.diff(u, axis=0)
        value -= self.smooth * float(np.sum(jumps**2)) / self.frames
        pull = np.zeros_like(u)
        pull[1:] += 2.0 * jumps
        pull[:-1] -= 2.0 * jumps
        if self.before is not None:
            into = u[0] - self.before
            value -= self.smooth * float(np.sum(into**2)) / self.frames
            pull[0] += 2.0 * into
        return value, slope / count, -self.smooth * pull / self.frames


def sequence_commands(
    model: PolyFace,
    targets: np.ndarray,
    start: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    *,
    features: list[int] | None = None,
    amplitude: float = AMPLITUDE,
    smooth: float = SMOOTH,
    iterations: int = ITERATIONS,
    offsets: np.ndarray | None = None,
    before: np.ndarray | None = None,
) -> Followed:
    """The commands (frames × servos, within ``low`` .. ``high``) whose self-model faces best
    follow ``targets`` (frames × the model's features, standardized) by the module's
    objective over the ``features`` (column indices; None: all), from ``start``;
    ``offsets`` (frames × those features; None: none) are added to the self-model's faces
    (what it got wrong, seen on the robot: :func:`rehearsed_commands`); ``before`` (one per
    servo; None: nothing) the commands held before the first frame, whose jump into it counts.

    ValueError for fewer than 3 frames, shapes that do not match, targets, starts or offsets
    that are not finite, a feature the targets do not move (its correlation has no meaning),
    bounds with ``low > high``, or negative weights."""
    minimize = _minimizer()

    targets = np.asarray(targets, dtype=np.float64)
    start = np.asarray(start, dtype=np.float64)
    low, high = np.asarray(low, dtype=np.float64), np.asarray(high, dtype=np.float64)
    columns = list(range(targets.shape[1])) if features is None else list(features)
    _check(model, targets, start, low, high, columns, amplitude, smooth)
    frames, servos = start.shape
    added = np.zeros((frames, len(columns))) if offsets is None else np.asarray(offsets, float)
    if added.shape != (frames, len(columns)) or not np.isfinite(added).all():
        raise ValueError(f"offsets must be finite, ({frames}, {len(columns)})")
    if before is not None:
        before = np.asarray(before, dtype=np.float64)
        if before.shape != (servos,) or not np.isfinite(before).all():
            raise ValueError(f"before must be {servos} finite commands")
    likeness = Likeness(targets, columns, amplitude, smooth, before)

    def objective(flat: np.ndarray) -> tuple[float, np.ndarray]:
        value, gradient = likeness_gradient(model, likeness, flat.reshape(frames, servos), added)
        return -value, -gradient.ravel()

    first = np.minimum(np.maximum(start, low), high)
    per_servo = list(zip(low.tolist(), high.tolist(), strict=True))
    with np.errstate(all="ignore"):
        result = minimize(
            objective,
            first.ravel(),
            jac=True,
            method="L-BFGS-B",
            bounds=per_servo * frames,
            options={"maxiter": iterations},
        )
    found = np.minimum(np.maximum(result.x.reshape(frames, servos), low), high)
    if not np.isfinite(found).all():  # the self-model overflowed: keep where it started
        found = first
    at_start, at_end = (model_faces(model, u, columns) + added for u in (first, found))
    return Followed(
        found,
        likeness.value(at_start, first),
        likeness.value(at_end, found),
        int(result.nit),
        likeness.mean_rho(at_start),
        likeness.mean_rho(at_end),
    )


def model_faces(model: PolyFace, u: np.ndarray, columns: list[int]) -> np.ndarray:
    """The self-model's faces (frames × ``columns``) at commands ``u`` (frames × servos)."""
    return np.array([model.at(np.append(v, 1.0))[0][columns] for v in u])


def _minimizer() -> Any:
    """SciPy's ``minimize`` (the ``learn`` extra brings SciPy with scikit-learn), or a
    ValueError naming the extra."""
    try:
        from scipy.optimize import minimize
    except ImportError:
        raise ValueError("planning needs SciPy: pip install 'facesynth[learn]'") from None
    return minimize


def likeness_gradient(
    model: PolyFace, likeness: Likeness, u: np.ndarray, offsets: np.ndarray
) -> tuple[float, np.ndarray]:
    """The objective of the self-model's faces at commands ``u`` (frames × servos) plus
    ``offsets`` (frames × the likeness's columns), and its gradient by ``u``."""
    frames, servos = u.shape
    columns = likeness.columns
    faces = np.empty((frames, len(columns)))
    jacobians = np.empty((frames, len(columns), servos))
    for k in range(frames):
        face, jacobian = model.at(np.append(u[k], 1.0))
        faces[k], jacobians[k] = face[columns], jacobian[columns]
    value, by_face, by_command = likeness.gradient(faces + offsets, u)
    return value, np.einsum("nj,njs->ns", by_face, jacobians) + by_command


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


def _check(
    model: PolyFace,
    targets: np.ndarray,
    start: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    columns: list[int],
    amplitude: float,
    smooth: float,
) -> None:
    frames = len(targets)
    if targets.ndim != 2 or start.ndim != 2 or frames < 3:
        raise ValueError("need targets and starts as frames x values, at least 3 frames")
    if start.shape != (frames, model.n_servos):
        raise ValueError(f"starts are {start.shape}, not ({frames}, {model.n_servos})")
    if targets.shape[1] != len(model.intercept):
        features = len(model.intercept)
        raise ValueError(f"targets have {targets.shape[1]} features, the model {features}")
    if low.shape != (model.n_servos,) or high.shape != (model.n_servos,) or np.any(low > high):
        raise ValueError("bounds need one low <= high per servo")
    if not (np.isfinite(targets).all() and np.isfinite(start).all()):
        raise ValueError("targets and starts must be finite")
    if not columns or any(not 0 <= c < targets.shape[1] for c in columns):
        raise ValueError(f"features must be column indices below {targets.shape[1]}")
    still = [c for c in columns if np.ptp(targets[:, c]) == 0]
    if still:
        raise ValueError(f"the targets do not move feature columns {still[:3]}")
    if not (amplitude >= 0 and smooth >= 0):
        raise ValueError("amplitude and smooth must be >= 0")


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
