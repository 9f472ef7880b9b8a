"""Where a learned profile loses its likeness on a simulated head: the loss budget (issue 27).

``python -m facesynth.app.bench.likeness_budget --head simhead16 --profile H.learned --frames 180``
plays the performer video through a learned profile onto a simulated head, as ``bench robot``
does, and measures the same lead figures (mean ρ and median amplitude ratio over the features
the performer moves and the robot moved while babbling), and the median amplitude ratio *in
reach* (against her change clipped into the profile's reach box, gain 1:
:func:`~facesynth.app.bench.robot_compare.reach_ratio`), at each stage of the way:

* **target**: T's retargeted target face itself (:mod:`facesynth.services.translator.retarget`),
  against the performer: what retargeting keeps;
* **oracle**: per frame, commands found by optimising through the *true* head (its actuators,
  render, our tracker and F, :class:`~facesynth.app.learn.inprocess.SimBabbler`) toward that
  target, with the same weights and the same objective as T's plan (damped Gauss-Newton on
  finite differences, started from T's own command and from the previous frame's): about the
  ceiling this head and tracker allow (a local search: 6 iterations instead of 2 raised it by
  0.04 of rho on 180 frames, 12 no further; it stalls on the noise of the head's settled face,
  docs/learning.md);
* **sequence**: the commands that follow the *whole* performance best by the lead figures'
  own measure (correlation, with the amplitude kept), searched through the self-model and
  rehearsed on the true head (:mod:`~facesynth.app.plan.sequence_rehearsed`): not causal, a
  frame's command knows the frames to come; what this head can show of this performance by
  the likeness measure (the oracle answers least squares per frame, a different question);
* **plan**: T's commands before its smoothing (inverse model + plan), the head settled at each
  (no dynamics): the inverse model and plan against the oracle;
* **sent**: the pulses C sent (T's smoothing and C's motion limits), settled at each;
* **live**: the head driven in time (:class:`~facesynth.app.engine.robot_loop.RobotLoop`, as
  ``bench robot`` runs it), at lag 0 and at the best lag of 0..:data:`LAGS`: the head's dynamics;
* **noise**: the head held still at a few poses, each reached from several others: how much F's
  features jitter there, against the performer's standard deviation (:func:`still_noise`).

Settled faces are looked at as the babbler looks (the pose settled, two tracked frames), so
the stages differ only in what commands the head.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from facesynth.app.bench.robot import Performance, reach_box, run_profile, track_performer
from facesynth.app.bench.robot_compare import FeatureRow, FeatureStream, compare, lead
from facesynth.app.learn.inprocess import SimBabbler
from facesynth.app.plan.sequence_rehearsed import ROUNDS, sequence_faces
from facesynth.app.plan.targets import translate
from facesynth.runtime.feature_names import NAMES
from facesynth.runtime.profiles import Profile, load_profile
from facesynth.runtime.profiles.learned import PolyRidge, shown_inputs

__all__ = ["LAGS", "Budget", "Faces", "Stage", "budget", "oracle_commands", "report", "still_noise"]

#: The largest lag (frames) the live run is also compared at.
LAGS = 5
#: Finite-difference step of the oracle (normalized command units).
STEP = 0.1
#: Gauss-Newton iterations of the oracle per frame.
ITERATIONS = 2


@dataclass(frozen=True)
class Stage:
    """One stage's lead figures and its rows (per feature); ``median_reach_ratio``: the
    median amplitude ratio against her change clipped into the robot's reach (gain 1)."""

    name: str
    mean_rho: float
    median_ratio: float
    rows: list[FeatureRow]
    median_reach_ratio: float = math.nan


@dataclass(frozen=True)
class Budget:
    """Every stage, the live run's best lag, and the still head's noise per lead feature
    (standard deviation over the performer's)."""

    features: tuple[str, ...]
    stages: list[Stage]
    best_lag: int
    noise: dict[str, float]


class Faces(Protocol):
    """What the oracle optimises through: a head's settled face for commands."""

    def face(self, u: np.ndarray) -> np.ndarray:
        """The face (one value per feature; NaN: not seen) with the head settled at ``u``."""


class Looker:
    """The head's settled face for normalized commands of a learned profile's outputs."""

    def __init__(self, profile: Profile, head: str) -> None:
        learned = profile.learned
        assert learned is not None
        self.babbler = SimBabbler(profile, head)
        names = [s.name for s in profile.servos]
        self.slots = [names.index(name) for name in learned.outputs]
        self.size = len(names)
        self.columns = [NAMES.index(name) for name in learned.inputs]
        self.looks = 0

    def face(self, u: np.ndarray) -> np.ndarray:
        """The learned inputs (raw, relative to the head's rest) with the outputs at ``u``."""
        full = np.zeros(self.size)
        full[self.slots] = u
        self.looks += 1
        out: np.ndarray = self.babbler.look(full)[self.columns]
        return out


def oracle_commands(
    looker: Faces,
    standardize: Callable[[np.ndarray], np.ndarray],
    x: np.ndarray,
    w: np.ndarray,
    starts: Sequence[np.ndarray],
) -> tuple[np.ndarray, np.ndarray]:
    """The command (and its face) nearest the standardized target ``x`` (weights ``w``) on the
    true head, from the best of ``starts``: damped Gauss-Newton on forward differences."""

    def cost(face: np.ndarray) -> float:
        error = np.nan_to_num(standardize(face) - x, nan=10.0)
        return float(np.sum(w * error**2))

    tried = [(cost(f), u, f) for u in starts for f in [looker.face(u)]]
    best, u, face = min(tried, key=lambda item: item[0])
    damping = 1e-2
    for _ in range(ITERATIONS):
        f0 = np.nan_to_num(standardize(face))
        jacobian = np.zeros((len(x), len(u)))
        for k in range(len(u)):
            h = STEP if u[k] + STEP <= 1.0 else -STEP
            probe = u.copy()
            probe[k] += h
            jacobian[:, k] = (np.nan_to_num(standardize(looker.face(probe))) - f0) / h
        weighted = jacobian * w[:, None]
        gradient = weighted.T @ (x - f0)
        normal = weighted.T @ jacobian
        for _attempt in range(2):
            step = np.linalg.solve(normal + damping * np.eye(len(u)), gradient)
            trial = np.clip(u + step, -1.0, 1.0)
            trial_face = looker.face(trial)
            trial_cost = cost(trial_face)
            if trial_cost < best:
                best, u, face = trial_cost, trial, trial_face
                damping = max(damping / 3.0, 1e-3)
                break
            damping *= 10.0
    return u, face


def still_noise(looker: Looker, poses: int = 5, approaches: int = 4, seed: int = 1) -> np.ndarray:
    """Each learned input's jitter (raw units): the standard deviation of the settled face at
    a pose over several approaches from other random poses, pooled over ``poses`` poses (the
    first the head's neutral)."""
    rng = np.random.default_rng(seed)
    n = len(looker.slots)
    variances = []
    for index in range(poses):
        pose = np.zeros(n) if index == 0 else rng.uniform(-0.8, 0.8, n)
        faces = []
        for _ in range(approaches):
            looker.face(rng.uniform(-1.0, 1.0, n))
            faces.append(looker.face(pose))
        variances.append(np.nanvar(np.array(faces), axis=0, ddof=1))
    out: np.ndarray = np.sqrt(np.nanmean(np.array(variances), axis=0))
    return out


def _stream(
    performance: Performance, inputs: list[str], faces: Sequence[np.ndarray | None]
) -> FeatureStream:
    frames = [None if f is None else dict(zip(inputs, f.tolist(), strict=True)) for f in faces]
    return FeatureStream.from_frames(frames, names=performance.stream.names)


def budget(
    performance: Performance,
    profile: Profile,
    head: str,
    *,
    oracle: bool = True,
    oracle_every: int = 1,
    rounds: int = ROUNDS,
    progress: Callable[[str], None] | None = None,
) -> Budget:
    """The loss budget of ``profile`` (learned, with a ``poly_ridge`` self-model or not) on the
    simulated ``head`` over ``performance`` (see the module's docstring); the oracle on every
    ``oracle_every``-th frame only (the other frames of its stage have no value); the
    sequence stage rehearsed ``rounds`` times (0, or a profile without a ``poly_ridge``
    self-model: no sequence stage)."""
    from facesynth.app.simhead import SimHead, load_head

    learned = profile.learned
    if learned is None:
        raise ValueError(f"profile {profile.name} is not learned")
    say = progress or (lambda _: None)
    inputs = list(learned.inputs)
    shown = set(shown_inputs(learned))
    mean = np.frombuffer(learned.input_mean.data, dtype=learned.input_mean.dtype)
    scale = np.frombuffer(learned.input_scale.data, dtype=learned.input_scale.dtype)

    def standardize(face: np.ndarray) -> np.ndarray:
        out: np.ndarray = (face - mean) / scale
        return out

    reach = reach_box(profile)

    def stage(name: str, stream: FeatureStream, lag: int = 0) -> Stage:
        rows = compare(performance.stream, stream, lag, reach=reach)
        figures = lead(rows, shown)
        return Stage(name, figures.mean_rho, figures.median_ratio, rows, figures.median_reach_ratio)

    stages = []
    wanted, weights, planned = translate(profile, performance.features)
    stages.append(stage("target", _stream(performance, inputs, wanted)))
    looker = Looker(profile, head)
    if oracle:
        say("oracle")
        found: list[np.ndarray | None] = []
        previous = np.zeros(len(looker.slots))
        for index, (t, w, u) in enumerate(zip(wanted, weights, planned, strict=True)):
            if t is None or index % oracle_every:
                found.append(None)
                continue
            previous, face = oracle_commands(looker, standardize, standardize(t), w, [u, previous])
            found.append(face)
            if index % 25 == 0:
                say(f"oracle frame {index}, {looker.looks} looks")
        stages.append(stage("oracle", _stream(performance, inputs, found)))
    if rounds and isinstance(learned.forward, PolyRidge):
        say("sequence")
        chosen = lead(stages[0].rows, shown).features
        faces = sequence_faces(profile, looker.face, wanted, planned, chosen, rounds)
        stages.append(stage("sequence", _stream(performance, inputs, faces)))
    say("plan")
    plan_faces = [
        None if t is None else looker.face(u) for t, u in zip(wanted, planned, strict=True)
    ]
    stages.append(stage("plan", _stream(performance, inputs, plan_faces)))
    say("live")
    recorder = _Recorder(SimHead(load_head(head)))
    live = run_profile(performance, profile, recorder)
    sent = recorder.sent[-len(performance.features) :]
    channels = {spec.name: spec.channel for spec in profile.servos}
    specs = [profile.servo(name) for name in learned.outputs]
    sent_faces: list[np.ndarray | None] = []
    for t, pulses in zip(wanted, sent, strict=True):
        if t is None:
            sent_faces.append(None)
            continue
        p = np.array([pulses.get(channels[s.name], s.neutral_us) for s in specs])
        n = np.array([s.neutral_us for s in specs])
        up = np.array([s.max_us - s.neutral_us for s in specs])
        down = np.array([s.neutral_us - s.min_us for s in specs])
        sent_faces.append(looker.face(np.where(p >= n, (p - n) / up, (p - n) / down)))
    best_lags = []
    for name, stream in (("sent", _stream(performance, inputs, sent_faces)), ("live", live)):
        lagged = [stage(f"{name}@{lag}", stream, lag) for lag in range(LAGS + 1)]
        best = max(lagged, key=lambda s: s.mean_rho)
        stages += [lagged[0], best]
        best_lags.append(lagged.index(best))
    say("noise")
    jitter = still_noise(looker)
    chosen = lead(stages[0].rows, shown).features
    noise = {}
    for name in chosen:
        theirs = performance.stream.column(name)
        spread = float(np.nanstd(theirs))
        noise[name] = float(jitter[inputs.index(name)]) / spread if spread > 0 else math.nan
    return Budget(chosen, stages, best_lags[-1], noise)


class _Recorder:
    """A head whose commanded pulses are kept at each render (one per camera frame)."""

    def __init__(self, head: object) -> None:
        self.head = head
        self.sent: list[dict[int, float]] = []

    def command(self, channel: int, pulse_us: float) -> None:
        self.head.command(channel, pulse_us)  # type: ignore[attr-defined]

    def step(self, t_ns: int) -> None:
        self.head.step(t_ns)  # type: ignore[attr-defined]

    def render(self) -> np.ndarray:
        self.sent.append(self.head.pulses())  # type: ignore[attr-defined]
        image: np.ndarray = self.head.render()  # type: ignore[attr-defined]
        return image


def report(result: Budget) -> str:
    """The budget as text: lead figures per stage, then per feature."""
    lines = [
        f"lead over {len(result.features)} features (mean rho / median amplitude ratio / the "
        f"same against her change clipped into the robot's reach, gain 1):"
    ]
    for s in result.stages:
        lines.append(
            f"  {s.name:<12} {s.mean_rho:5.2f} / {s.median_ratio:4.2f} / "
            f"{s.median_reach_ratio:4.2f}"
        )
    noise = [v for v in result.noise.values() if math.isfinite(v)]
    lines.append(
        f"  still-head noise / performer std: median {np.median(noise):.2f}, max {max(noise):.2f}"
    )
    header = "feature".ljust(24) + "".join(s.name[:10].rjust(11) for s in result.stages)
    lines += ["", "rho per feature:", header + "   noise"]
    by_stage = [{row.name: row for row in s.rows} for s in result.stages]
    for name in result.features:
        cells = "".join(f"{rows[name].rho:11.2f}" for rows in by_stage)
        lines.append(name.ljust(24) + cells + f"   {result.noise[name]:.2f}")
    lines += ["", "amplitude ratio per feature:", header]
    for name in result.features:
        cells = "".join(f"{rows[name].ratio:11.2f}" for rows in by_stage)
        lines.append(name.ljust(24) + cells)
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Print the budget of a learned profile on a simulated head (exit 2 with one line on bad
    input: an unknown head, a profile that is not learned, no frames)."""
    from facesynth.app.data import sample_video
    from facesynth.app.simhead import load_head

    parser = argparse.ArgumentParser(prog="python -m facesynth.app.bench.likeness_budget")
    parser.add_argument("--head", default="simhead16")
    parser.add_argument("--profile", required=True, help="a learned profile (file or name)")
    parser.add_argument("--frames", type=int, default=None, help="performer frames (all)")
    parser.add_argument("--no-oracle", action="store_true", help="skip the (slow) oracle")
    parser.add_argument("--oracle-every", type=int, default=1, help="the oracle on every Nth frame")
    parser.add_argument(
        "--rounds", type=int, default=ROUNDS, help="rehearsals of the sequence stage (0: none)"
    )
    args = parser.parse_args(argv)
    try:
        if args.oracle_every < 1:
            raise ValueError(f"--oracle-every must be at least 1 (got {args.oracle_every})")
        if args.rounds < 0:
            raise ValueError(f"--rounds must be 0 or more (got {args.rounds})")
        load_head(args.head)
        profile = load_profile(args.profile)
        if profile.learned is None:
            raise ValueError(f"profile {profile.name} is not learned (facesynth learn writes one)")
        performance = track_performer(str(sample_video()), frames=args.frames)
        result = budget(
            performance,
            profile,
            args.head,
            oracle=not args.no_oracle,
            oracle_every=args.oracle_every,
            rounds=args.rounds,
            progress=lambda what: print(what, file=sys.stderr, flush=True),
        )
    except ValueError as exc:  # RobotError, ProfileError and a head's errors are ValueErrors
        parser.exit(2, f"{parser.prog}: error: {exc}\n")
    print(report(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
