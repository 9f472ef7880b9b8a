"""``facesynth bench smoothing``: jitter on a still face and lag on a step, through T.

Synthetic features go through :class:`services.translator.core.Translator` with a profile's
parameters (default: the shipped ``paper16``) at a fixed frame rate, for chosen servos (default:
``right_eyebrow``, a Table 1 group, and ``right_eye_x``, iris gaze), in three chains:

* ``unfiltered``: the paper's mapping only (no smoothing, dead-band or speed limits);
* ``one euro``: the profile's One Euro filter only;
* ``shipped``: the whole T output as the profile ships (filter, dead-band, gain, speed and
  acceleration limits).

(a) **Jitter**: a still face (all deltas and named features 0) plus Gaussian noise at the
tracker's noise level (one draw per frame shared by all 68 deltas, so every group mean has the
measured sigma; an independent draw per named feature); reported as the standard deviation and
peak-to-peak of the servo output in µs (after the first second). (b) **Step**: a clean step of
the source to half its positive range (points: 0.5 face_max; named: a scaled 0.5); reported as
the time from the step to the first frame at or beyond 50 % and 90 % of the output's change
(frame-quantised).

The noise levels are measured on a ``facesynth track`` file (``track=``) as the robust
(median-absolute-deviation) standard deviation of second differences, which removes slow real
motion: ``sigma = 1.4826 * MAD(x[t+1] - 2 x[t] + x[t-1]) / sqrt(6)``. Without a track the defaults
below are used: measured that way on the bundled video (472 frames, the tracker's ``ibug68`` and
``iris10``), right brow group mean and right iris x (iris centre offset along the eye-corner
axis, in eye widths, divided by the contract's default range of gaze_right_x, 0.12).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import msgspec
import numpy as np

from facesynth.app.engine.stepped import RobotCores, SteppedChain
from facesynth.runtime.feature_names import BY_NAME
from facesynth.runtime.landmarks import N_IBUG
from facesynth.runtime.profiles import Profile, ServoSpec, Smoothing, describe_source, load_profile
from facesynth.schemas.messages import Features

#: Tracker noise on a still face, measured on the bundled video (see the module docstring).
DEFAULT_SIGMA_IOD = 0.0034  # right brow group mean distance to the nose tip, IOD units
DEFAULT_SIGMA_SCALED = 0.09  # gaze_right_x, scaled units (0.011 eye widths / 0.12)

#: The servos reported by default (paper16): a Table 1 group and an iris-driven eye.
DEFAULT_SERVOS = ("right_eyebrow", "right_eye_x")
BROW_GROUP = [17, 18, 19, 20]
CHAINS = ("unfiltered", "one euro", "shipped")


def _robust_sigma(values: np.ndarray) -> float:
    second = values[2:] - 2.0 * values[1:-1] + values[:-2]
    mad = float(np.median(np.abs(second - np.median(second))))
    return 1.4826 * mad / math.sqrt(6.0)


def measure_noise(track: str | Path) -> dict[str, float]:
    """Tracker noise from a ``facesynth track`` JSON-lines file (see the module docstring)."""
    from facesynth.services.features.core import normalise, nose_distances

    brow, gaze = [], []
    for line in Path(track).read_text(encoding="utf-8").splitlines():
        if not line.strip():
            continue
        row = json.loads(line)
        if not row.get("face") or not row.get("ibug68"):
            continue
        points = np.asarray(row["ibug68"], dtype=np.float64).reshape(N_IBUG, 2)
        brow.append(float(nose_distances(normalise(points))[BROW_GROUP].mean()))
        if row.get("iris"):
            centre = np.asarray(row["iris"], dtype=np.float64).reshape(-1, 2)[0]
            outer, inner = points[36], points[39]
            width = float(np.hypot(*(inner - outer)))
            axis = (inner - outer) / width
            gaze.append(float(np.dot(centre - (outer + inner) / 2.0, axis)) / width)
    if len(brow) < 3:
        raise ValueError(f"{track}: fewer than 3 frames with a face")
    out = {"sigma_iod": _robust_sigma(np.asarray(brow)), "frames": float(len(brow))}
    if len(gaze) >= 3:
        out["sigma_scaled"] = _robust_sigma(np.asarray(gaze)) / BY_NAME["gaze_right_x"].default_max
    return out


def _variant(profile: Profile, chain: str) -> Profile:
    if chain == "shipped":
        return profile
    servos = [
        msgspec.structs.replace(
            spec, max_speed=0.0, max_accel=0.0, deadband=0.0, gain=1.0, smoothing=None
        )
        if chain == "unfiltered"
        else msgspec.structs.replace(spec, max_speed=0.0, max_accel=0.0, deadband=0.0, gain=1.0)
        for spec in profile.servos
    ]
    smoothing = None if chain == "unfiltered" else profile.smoothing
    return msgspec.structs.replace(profile, servos=servos, smoothing=smoothing)


def _run(
    profile: Profile, deltas: np.ndarray, named: list[dict[str, float]], fps: float
) -> list[dict[str, float]]:
    """Feed frames through T: ``deltas`` one value per frame for every point, ``named`` the
    named features per frame; T's commands (stepped with C, on media time, as a ``--fast``
    chain runs them)."""
    chain = SteppedChain(robots=[RobotCores.of_profile("t", profile, motion_time="media")])
    out = []
    for index, (delta, values) in enumerate(zip(deltas, named, strict=True)):
        features = Features(
            seq=index,
            t_capture_ns=0,
            t_media_ns=round(index * 1e9 / fps),
            face=True,
            neutral_ready=True,
            deltas=[float(delta)] * N_IBUG,
            named=values,
        )
        out.append(chain.step(features).commands["t"].positions)
    return out


def _step_source(spec: ServoSpec, size: float) -> tuple[float, dict[str, float]]:
    """The delta (all points) and named features that move ``spec``'s source by ``size`` of its
    positive range."""
    weights = spec.weights()
    if weights is None:
        return size * (spec.face_max or 0.0), {}
    total = sum(abs(w) for w in weights.values())
    return 0.0, {name: size * math.copysign(1.0, w) / total for name, w in weights.items()}


def _crossing_ms(output: list[float], start: int, fps: float, level: float) -> float | None:
    before, after = output[start - 1], output[-1]
    change = after - before
    for index in range(start, len(output)):
        if (output[index] - before) / change >= level - 1e-9:
            return (index - start) * 1000.0 / fps
    return None


def bench_smoothing(
    profile: str = "paper16",
    *,
    servos: list[str] | None = None,
    fps: float = 30.0,
    seconds: float = 20.0,
    seed: int = 0,
    track: str | Path | None = None,
    sigma_iod: float | None = None,
    sigma_scaled: float | None = None,
) -> dict[str, Any]:
    """Jitter and step lag of T's output for ``profile`` (see the module docstring).

    ``servos``: the servos to report (default: right_eyebrow and right_eye_x when the profile
    has them, else its first two servos).
    """
    base = load_profile(profile)
    names = {spec.name for spec in base.servos}
    if servos is None:
        servos = [n for n in DEFAULT_SERVOS if n in names] or [s.name for s in base.servos[:2]]
    unknown = [n for n in servos if n not in names]
    if unknown:
        raise ValueError(f"profile {base.name!r} has no servos {unknown}")
    if not fps > 0 or not seconds > 0:
        raise ValueError("fps and seconds must be positive")
    noise_source = "defaults measured on the bundled video"
    if track is not None:
        measured = measure_noise(track)
        sigma_iod = measured["sigma_iod"] if sigma_iod is None else sigma_iod
        if sigma_scaled is None and "sigma_scaled" in measured:
            sigma_scaled = measured["sigma_scaled"]
        noise_source = f"measured on {track} ({int(measured['frames'])} frames)"
    sigma_iod = DEFAULT_SIGMA_IOD if sigma_iod is None else sigma_iod
    sigma_scaled = DEFAULT_SIGMA_SCALED if sigma_scaled is None else sigma_scaled

    features = sorted({n for spec in base.servos for n in spec.weights() or {}})
    frames = max(round(seconds * fps), 3 * round(fps))
    rng = np.random.default_rng(seed)
    still_deltas = rng.normal(0.0, sigma_iod, frames)
    noise = rng.normal(0.0, sigma_scaled, (frames, len(features)))
    still_named = [dict(zip(features, map(float, row), strict=True)) for row in noise]
    warm = round(fps)  # the first second is left out of the jitter figures
    step_at, step_frames = round(fps), 3 * round(fps)

    rows = []
    for chain in CHAINS:
        variant = _variant(base, chain)
        still = _run(variant, still_deltas, still_named, fps)
        for name in servos:
            delta, named = _step_source(base.servo(name), 0.5)
            step_deltas = np.where(np.arange(step_frames) >= step_at, delta, 0.0)
            step_named = [
                {n: (v if i >= step_at else 0.0) for n, v in named.items()}
                for i in range(step_frames)
            ]
            step = [o[name] for o in _run(variant, step_deltas, step_named, fps)]
            jitter = np.asarray([o[name] for o in still[warm:]])
            rows.append(
                {
                    "servo": name,
                    "chain": chain,
                    "jitter_std_us": float(np.std(jitter)),
                    "jitter_p2p_us": float(np.ptp(jitter)),
                    "step_us": step[-1] - step[step_at - 1],
                    "step_50_ms": _crossing_ms(step, step_at, fps, 0.5),
                    "step_90_ms": _crossing_ms(step, step_at, fps, 0.9),
                }
            )
    smoothing = base.smoothing
    return {
        "profile": base.name,
        "fps": fps,
        "frames": frames,
        "seed": seed,
        "noise": {"sigma_iod": sigma_iod, "sigma_scaled": sigma_scaled, "source": noise_source},
        "smoothing": None if smoothing is None else msgspec.to_builtins(smoothing),
        "servos": {
            name: {
                "source": describe_source(base.servo(name)),
                "smoothing": _describe(base.smoothing_for(base.servo(name))),
            }
            for name in servos
        },
        "rows": rows,
    }


def _describe(params: Smoothing | None) -> str:
    if params is None:
        return "no smoothing"
    return f"One Euro min_cutoff {params.min_cutoff:g} Hz, beta {params.beta:g}, " + (
        f"d_cutoff {params.d_cutoff:g} Hz"
    )


def _ms(value: float | None) -> str:
    return "never" if value is None else f"{value:.0f}"


def format_smoothing(result: dict[str, Any]) -> str:
    """A small text table of :func:`bench_smoothing`'s result."""
    noise = result["noise"]
    lines = [
        f"profile {result['profile']}, {result['fps']:g} fps, {result['frames']} still frames, "
        f"seed {result['seed']}",
        f"noise: {noise['sigma_iod']:.4f} IOD on point groups, {noise['sigma_scaled']:.3f} on "
        f"named features ({noise['source']})",
    ]
    for name, info in result["servos"].items():
        lines.append(f"{name}: {info['source']}; {info['smoothing']}")
    lines.append("")
    lines.append(
        f"{'servo':<16} {'chain':<11} {'jitter std µs':>13} {'p-p µs':>7} "
        f"{'step µs':>8} {'50% ms':>7} {'90% ms':>7}"
    )
    for row in result["rows"]:
        lines.append(
            f"{row['servo']:<16} {row['chain']:<11} {row['jitter_std_us']:>13.1f} "
            f"{row['jitter_p2p_us']:>7.0f} {row['step_us']:>8.0f} {_ms(row['step_50_ms']):>7} "
            f"{_ms(row['step_90_ms']):>7}"
        )
    lines.append(f"(step times are frame-quantised: {1000.0 / result['fps']:.1f} ms per frame)")
    return "\n".join(lines)
