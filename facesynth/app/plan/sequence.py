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

from dataclasses import dataclass
from typing import Any

import numpy as np

from facesynth.services.translator.self_model_face import PolyFace

__all__ = [
    "AMPLITUDE",
    "ITERATIONS",
    "SMOOTH",
    "Followed",
    "Likeness",
    "likeness_gradient",
    "model_faces",
    "sequence_commands",
]

#: Weight of the amplitude term (log² of the robot's spread over the target's, per feature).
AMPLITUDE = 0.3
#: Weight of the jump term (mean squared change of the commands between frames).
SMOOTH = 0.5
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
    (what it got wrong, seen on the robot:
    :func:`~facesynth.app.plan.sequence_rehearsed.rehearsed_commands`); ``before`` (one per
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
