"""Fit a learned profile from babbling: the robot's self-model and its inverse (scikit-learn).

:func:`fit_learned_profile` takes a :class:`~facesynth.app.learn.dataset.BabbleSet` and the
hardware profile it was babbled with and returns that profile with its
:class:`~facesynth.runtime.profiles.Learned` mapping (save it with
:func:`~facesynth.runtime.profiles.save_learned_profile`):

1. **Inputs.** The features the robot actually moved: present (finite) in at least
   ``min_present`` of the samples, and with a spread (standard deviation) of at least
   ``min_std`` of the feature's default range (:mod:`facesynth.runtime.feature_names`). Rows with
   NaN in a chosen input are dropped (counted in the report). Each input is taken relative to
   the robot's neutral (the median of the ``"neutral"`` samples, when there are any);
   ``reach_low`` / ``reach_high`` are its 1st / 99th percentiles (0 included).
2. **Dead servos.** A forward model (ridge on degree-2 polynomial features of every servo's
   normalized command ``u``) predicts the standardized inputs; a servo whose full travel
   (``u`` = ±1, the others at neutral) moves no input by ``dead_effect`` standard deviations is
   dead: its command moved nothing the camera sees, so it stays at neutral. A servo the
   babbling has not moved both ways from neutral (a session stopped before its sweeps) is not
   dead but *not exercised* (:mod:`facesynth.app.learn.coverage`): the fit refuses such a
   session (:class:`~facesynth.app.learn.coverage.UnsweptError`) unless ``partial``, which
   keeps those servos at neutral and names them in the report. Held-out errors cover the
   fitted servos only.
3. **Inverse model.** Candidates (ridge on degree-2 polynomial features with a per-servo
   penalty by generalized cross-validation, k nearest neighbours, a small tanh MLP at each
   penalty of ``mlp_alphas``, the mean of ``mlp_members`` seeded ones; fitted on one BLAS
   thread: on these small matrices more threads only fight over the cores) are trained on the
   poses of a seeded split by pose (a pose visited twice, e.g. the neutral, is on one side only)
   and compared by their command error on the held-out poses: the mean absolute error in µs, as
   a fraction of each servo's range (``max_us - min_us``). The best is refitted on every pose.
   Then the **regional** inverse (``regional``, :mod:`facesynth.app.learn.regional`): each
   servo's own model on the features its region moves (from the sweeps), kept for the servos
   whose held-out error it keeps within ``MARGIN`` of the best candidate's, the others from
   that candidate on the whole face; the whole is kept when its commands' faces (through a
   self-model fitted on the training poses) stay within ``FACE_MARGIN`` of the best's.
   The face's regions and symmetric pairs, found from the sweeps, go into the report; with
   ``recombined`` > 0 and a session that babbled the regions, faces recombined from them are
   added to the training poses (never to the held-out ones: :mod:`facesynth.app.learn.augment`).
4. **Forward model** on the live servos (the same ridge) is kept in the file as the robot's
   self-model: ``u`` → standardized inputs.
5. **Responsive ranges.** Each live servo's ``[command_low, command_high]``, the part of its
   travel over which the face still changes (one-sided and saturating actuators), from the
   sweeps and the neutral noise (:mod:`facesynth.app.learn.responsive`). Both models are fitted
   on commands clipped into it (any command beyond gives the same face), and the report gives
   two held-out errors: *raw* (predicted against babbled command) and *effective* (both
   clipped into the range first). Candidates are compared, and issue 17's goal (<= 0.05 of
   range) is measured, on the effective error.
6. **Retargeting.** Each input's ``noise``: the standard deviation of what the commands do
   not explain (:mod:`facesynth.app.learn.unexplained`: camera jitter, tracker hysteresis, a
   feature moved by nothing the robot commands), from which T tells the features the robot
   can show; and T's retargeting options (``retarget``; :mod:`services.translator.retarget`).

scikit-learn is imported by the model families only (:mod:`facesynth.app.learn.models`, the
``learn`` extra); the board side runs the result in numpy
(:func:`facesynth.runtime.profiles.learned_predict.predictor`, which gives what these
scikit-learn models' ``predict`` give).
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass
from datetime import UTC, datetime

import msgspec
import numpy as np

from facesynth.app.learn.augment import Recombination
from facesynth.app.learn.coverage import UnsweptError, coverage
from facesynth.app.learn.dataset import BabbleSet
from facesynth.app.learn.lag import lag_notes
from facesynth.app.learn.models import (
    CANDIDATES,
    FITTERS,
    FitError,
    FitOptions,
    candidate_variants,
    fit_model,
    poly_ridge,
    require_sklearn,
    sklearn_predict,
)
from facesynth.app.learn.regional import (
    FACE_MARGIN,
    Faces,
    compose,
    fit_parts,
    kept,
    own_predictions,
    regional_notes,
    servo_inputs,
)
from facesynth.app.learn.regions import regions_from_sweeps
from facesynth.app.learn.report import format_report
from facesynth.app.learn.responsive import clip_commands, responsive_range
from facesynth.app.learn.unexplained import unexplained
from facesynth.runtime.feature_names import BY_NAME
from facesynth.runtime.profiles import Learned, Profile
from facesynth.runtime.profiles.learned import Model, Report, pack
from facesynth.runtime.profiles.learned_retarget import fitted_retarget

__all__ = [
    "CANDIDATES",
    "FITTERS",
    "FitError",
    "FitOptions",
    "command_error",
    "fit_learned_profile",
    "fit_model",
    "format_report",
    "main",
    "sklearn_predict",
]

# --- the data ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Data:
    inputs: list[str]
    t: np.ndarray  # (n, d) relative to the robot's neutral
    u: np.ndarray  # (n, S) normalized commands
    groups: np.ndarray  # (n,) pose index
    kinds: np.ndarray  # (n,) sample kinds
    dropped: int
    notes: list[str]


def _choose_inputs(babble: BabbleSet, u: np.ndarray, options: FitOptions) -> _Data:
    faces = np.asarray(babble.faces, dtype=np.float64)
    present = np.isfinite(faces).mean(axis=0) if len(faces) else np.zeros(faces.shape[1])
    kinds = np.asarray(babble.kinds)
    neutral_rows = faces[kinds == "neutral"]
    notes = []
    chosen = []
    for column, name in enumerate(babble.inputs):
        feature = BY_NAME.get(name)
        if feature is None:
            notes.append(f"input {name!r} is not a feature: left out")
            continue
        if present[column] < options.min_present:
            notes.append(f"input {name} present in {present[column]:.0%} of samples: left out")
            continue
        spread = float(np.nanstd(faces[:, column]))
        if spread >= options.min_std * (feature.default_max - feature.default_min):
            chosen.append(column)
    if not chosen:
        raise FitError("the babbling moved no feature: is the camera on the robot's face?")
    values = faces[:, chosen]
    keep = np.all(np.isfinite(values), axis=1)
    dropped = int((~keep).sum())
    if dropped:
        notes.append(f"{dropped} samples with a missing chosen input dropped")
    offset = np.zeros(len(chosen))
    if len(neutral_rows):
        with warnings.catch_warnings():  # an input never seen at neutral: offset 0
            warnings.simplefilter("ignore", RuntimeWarning)
            offset = np.nan_to_num(np.nanmedian(neutral_rows[:, chosen], axis=0))
    _, groups = np.unique(np.round(babble.commands[keep], 1), axis=0, return_inverse=True)
    groups = np.asarray(groups).reshape(-1)
    stretches = babble.stretches()[keep]
    streamed = stretches >= 0  # a stream's frames: grouped by stretch, never one by one
    groups = np.where(streamed, groups.max(initial=-1) + 1 + stretches, groups)
    return _Data(
        inputs=[str(babble.inputs[c]) for c in chosen],
        t=values[keep] - offset,
        u=u[keep],
        groups=groups,
        kinds=np.asarray(babble.kinds)[keep],
        dropped=dropped,
        notes=notes,
    )


def _split(groups: np.ndarray, options: FitOptions) -> tuple[np.ndarray, np.ndarray]:
    """Row masks (train, held out): a seeded share of the poses held out."""
    poses = np.unique(groups)
    rng = np.random.default_rng(options.seed)
    n_out = round(len(poses) * options.held_out)
    if len(poses) < 10 or n_out < 1:
        raise FitError(f"{len(poses)} different poses: too few to fit and check a model")
    out = np.isin(groups, rng.permutation(poses)[:n_out])
    return ~out, out


def _ranges(profile: Profile, servos: list[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    specs = [profile.servo(name) for name in servos]
    neutral = np.array([s.neutral_us for s in specs])
    up = np.array([s.max_us - s.neutral_us for s in specs])
    down = np.array([s.neutral_us - s.min_us for s in specs])
    return neutral, up, down


def command_error(
    profile: Profile, servos: list[str], u: np.ndarray, wanted: np.ndarray
) -> np.ndarray:
    """Per servo, the mean absolute error of commands ``u`` against ``wanted`` (both (n, S)
    normalized), in µs as a fraction of the servo's range (max_us - min_us)."""
    neutral, up, down = _ranges(profile, servos)

    def pulses(v: np.ndarray) -> np.ndarray:
        v = np.clip(v, -1.0, 1.0)
        out: np.ndarray = neutral + np.where(v >= 0, v * up, v * down)
        return out

    error: np.ndarray = np.abs(pulses(u) - pulses(wanted)).mean(axis=0) / (up + down)
    return error


def _dead(x: np.ndarray, u: np.ndarray, options: FitOptions) -> np.ndarray:
    """Per servo: whether its full travel moves no input by ``dead_effect`` std."""
    fitted, _ = poly_ridge(u, x, options)
    n = u.shape[1]
    probes = np.vstack([np.zeros(n), np.eye(n), -np.eye(n)])
    predicted = sklearn_predict(fitted, probes)
    effect = np.abs(predicted[1:] - predicted[0]).max(axis=1)
    effect = np.maximum(effect[:n], effect[n:])
    dead: np.ndarray = effect < options.dead_effect
    return dead


def fit_learned_profile(
    babble: BabbleSet, profile: Profile, options: FitOptions | None = None
) -> Profile:
    """``profile`` (a hardware profile) with the mapping fitted on ``babble`` (see the module).

    Raises :class:`FitError` when the data cannot give a model (no moving feature, too few
    poses, servos the profile lacks, no servo moving the face), and
    :class:`~facesynth.app.learn.coverage.UnsweptError` when some servo was not moved both
    ways from neutral (unless ``options.partial``).
    """
    options = options or FitOptions()
    require_sklearn()
    from threadpoolctl import threadpool_limits  # a dependency of scikit-learn

    # One core: multithreaded BLAS on these small matrices only fights over the cores (a
    # 50-fold slow-down measured on a loaded two-core machine).
    with threadpool_limits(limits=1):
        return _fit(babble, profile, options)


def _fit(babble: BabbleSet, profile: Profile, options: FitOptions) -> Profile:
    started = time.perf_counter()
    names = [spec.name for spec in profile.servos]
    unknown = [name for name in babble.servos if name not in names]
    if unknown:
        raise FitError(f"the babbling commanded servos {unknown} that profile {profile.name} lacks")
    unknown_models = [c for c in options.candidates if c not in FITTERS]
    if unknown_models or not options.candidates:
        raise FitError(f"unknown models {unknown_models} (known: {', '.join(FITTERS)})")
    cover = coverage(babble, profile)
    if cover.unswept and not options.partial:
        raise UnsweptError(cover)
    u_all = babble.normalized(profile)
    data = _choose_inputs(babble, u_all, options)
    mean = data.t.mean(axis=0)
    scale = data.t.std(axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    x = (data.t - mean) / scale
    servos = [str(name) for name in babble.servos]  # numpy strings do not encode
    # kept at neutral: dead (moved nothing), and not swept yet (only with options.partial)
    dead_mask = _dead(x, data.u, options) | np.isin(servos, cover.unswept)
    live = [s for s, d in zip(servos, dead_mask, strict=True) if not d]
    dead = [s for s in names if s not in live]
    if not live:
        raise FitError("no servo moved the face while babbling")
    u_low, u_high = (r[~dead_mask] for r in responsive_range(data.t, data.u, data.kinds))
    raw_y = data.u[:, ~dead_mask]
    y = clip_commands(raw_y, u_low, u_high)  # commands that give the same face, as one
    train, test = _split(data.groups, options)
    regions = regions_from_sweeps(
        babble.faces, u_all, np.asarray(babble.kinds), tuple(servos), list(babble.inputs)
    )
    own = servo_inputs(regions, data.inputs, live) if options.regional else []
    more = Recombination(data.t, data.u, x, y, (mean, scale), (u_low, u_high), ~dead_mask)
    use, verdict = more.helps(regions, train, data.kinds, options)
    x_train, y_train = more.rows(regions, train, options) if use else (x[train], y[train])
    errors: dict[str, np.ndarray] = {}
    raw_errors: dict[str, np.ndarray] = {}
    seconds: dict[str, float] = {}
    variants = candidate_variants(options)
    face = Faces(poly_ridge(y[train], x[train], options)[0], x[test], u_low, u_high)
    predictions: dict[str, np.ndarray] = {}

    def judge(label: str, predicted: np.ndarray) -> None:
        face.add(label, predicted)
        predictions[label] = predicted
        raw_errors[label] = command_error(profile, live, predicted, raw_y[test])
        errors[label] = command_error(
            profile, live, clip_commands(predicted, u_low, u_high), y[test]
        )

    for label, (name, variant) in variants.items():
        begun = time.perf_counter()
        fitted, _ = fit_model(name, x_train, y_train, variant)
        judge(label, sklearn_predict(fitted, x[test]))
        seconds[label] = time.perf_counter() - begun
    best = min(errors, key=lambda label: float(errors[label].mean()))
    family, variant = variants[best]
    keep = np.zeros(len(live), dtype=bool)
    if any(own):  # each servo from its region's features where that does as well (regional.py)
        begun = time.perf_counter()
        mine = own_predictions(x_train, y_train, x[test], own, options)
        filled = np.where(np.isnan(mine), predictions[best], mine)
        mine_error = command_error(profile, live, clip_commands(filled, u_low, u_high), y[test])
        keep = kept(mine_error, errors[best], own)
        label = f"regional {best}"
        judge(label, np.where(keep, filled, predictions[best]))
        seconds[label] = time.perf_counter() - begun
        if keep.any() and face.errors[label] <= face.errors[best] + FACE_MARGIN:
            best = label
    noise = scale * unexplained(
        x, y, data.groups, lambda a, b, c: sklearn_predict(poly_ridge(a, b, options)[0], c)
    )
    everything = np.ones(len(x), dtype=bool)
    x_all, y_all = more.rows(regions, everything, options) if use else (x, y)
    inverse: Model = (
        fit_parts(compose(own, keep, len(data.inputs)), (family, variant), x_all, y_all, options)[1]
        if best.startswith("regional ")
        else fit_model(family, x_all, y_all, variant)[1]
    )
    _, forward = poly_ridge(y, x, options)
    low = np.minimum(np.percentile(data.t, 1, axis=0), 0.0)
    high = np.maximum(np.percentile(data.t, 99, axis=0), 0.0)
    notes = data.notes + [f"{name} fitted in {seconds[name]:.1f} s" for name in seconds]
    notes += regions.notes() + ([verdict] if verdict else []) + face.notes()
    notes += regional_notes(live, own, keep, best)
    lags = {servo: babble.lags[servo] for servo in live if servo in babble.lags}
    notes += lag_notes(lags)
    if cover.unswept:
        notes.insert(0, f"partial fit: {UnsweptError(cover)} (kept at neutral)")
    report = Report(
        model=best,
        servo_error={s: float(e) for s, e in zip(live, raw_errors[best], strict=True)},
        candidates={name: float(e.mean()) for name, e in raw_errors.items()},
        effective_error={s: float(e) for s, e in zip(live, errors[best], strict=True)},
        effective_candidates={name: float(e.mean()) for name, e in errors.items()},
        samples=len(x),
        held_out=int(test.sum()),
        dropped=data.dropped,
        fit_seconds=round(time.perf_counter() - started, 3),
        created=datetime.now(UTC).isoformat(timespec="seconds"),
        notes=notes,
        not_exercised=[str(name) for name in cover.not_exercised],
        one_way=[str(name) for name in cover.one_way],
    )
    learned = Learned(
        inputs=data.inputs,
        reach_low=pack(low),
        reach_high=pack(high),
        input_mean=pack(mean),
        input_scale=pack(scale),
        outputs=live,
        dead=dead,
        inverse=inverse,
        forward=forward,
        plan_steps=options.plan_steps,
        plan_prior=options.plan_prior,
        command_low=pack(u_low),
        command_high=pack(u_high),
        noise=pack(noise),
        retarget=fitted_retarget(),
        report=report,
    )
    return msgspec.structs.replace(profile, learned=learned)


def main(argv: list[str] | None = None) -> int:
    """``python -m facesynth.app.learn.fit PROFILE [--frames N]``: a learned profile's fit
    report and T's milliseconds per frame with it."""
    import argparse

    from facesynth.runtime.profiles import load_profile
    from facesynth.services.translator.timing import time_translator

    parser = argparse.ArgumentParser(prog="python -m facesynth.app.learn.fit")
    parser.add_argument("profile", help="a learned profile (NAME or PATH.learned)")
    parser.add_argument("--frames", type=int, default=2000)
    args = parser.parse_args(argv)
    profile = load_profile(args.profile)
    print(format_report(profile))
    print(f"T: {time_translator(profile, args.frames):.3f} ms per frame")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
