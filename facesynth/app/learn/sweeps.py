"""What the sweeps showed: servos that move nothing the camera sees, and each one's dead band.

Pure numpy, from a session's samples. The neutral poses give each feature's resting value and
its noise (the spread between neutral poses, and within them); a sweep pose moved the face when
some feature left its resting value by more than ``NOISE_K`` noises (and ``MIN_CHANGE``). A
servo none of whose sweep poses moved the face is dead; otherwise its dead band on each side is
the smallest command (normalized, |u|) that moved it. Head pose is left out: the robot's head
stays where it is bolted, and its estimate only wobbles as the face's features move.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from facesynth.runtime.profiles import Profile
from facesynth.schemas.messages import BabbleSample
from facesynth.services.features.expressions import HEAD

#: A feature moved when it changed by more than this many noise levels …
NOISE_K = 4.0
#: … and by more than this (raw feature units).
MIN_CHANGE = 0.01


@dataclass(frozen=True)
class ServoResponse:
    """One servo's sweeps: the feature it moves most (and by how much), dead or not, and the
    smallest normalized command that moved the face on each side (1.0: nothing moved)."""

    servo: str
    feature: str
    change: float
    dead: bool
    below: float
    above: float


def _normalized(spec_min: float, neutral: float, spec_max: float, value: float) -> float:
    if value >= neutral:
        return (value - neutral) / (spec_max - neutral) if spec_max > neutral else 0.0
    return (value - neutral) / (neutral - spec_min) if neutral > spec_min else 0.0


def sweep_report(samples: list[BabbleSample], profile: Profile) -> list[ServoResponse]:
    """Each swept servo's response (servos without sweep poses are left out)."""
    neutrals = [s for s in samples if s.kind == "neutral" and s.features]
    if not neutrals:
        return []
    names = sorted(set.intersection(*(set(s.features) for s in neutrals)) - set(HEAD))
    if not names:
        return []
    rest = np.array([[s.features[n] for n in names] for s in neutrals])
    within = np.array([[s.spread.get(n, 0.0) for n in names] for s in neutrals])
    noise = np.sqrt(rest.std(axis=0) ** 2 + (within**2).mean(axis=0))
    threshold = np.maximum(NOISE_K * noise, MIN_CHANGE)
    base = rest.mean(axis=0)
    neutral = profile.neutral_positions()
    specs = {spec.name: spec for spec in profile.servos}
    moves: dict[str, list[tuple[float, np.ndarray]]] = {}
    for sample in samples:
        if sample.kind != "sweep":
            continue
        swept = [n for n, v in sample.commanded.items() if abs(v - neutral.get(n, v)) > 1e-6]
        if len(swept) != 1 or swept[0] not in specs:
            continue
        spec = specs[swept[0]]
        u = _normalized(spec.min_us, spec.neutral_us, spec.max_us, sample.commanded[spec.name])
        values = np.array([sample.features.get(n, np.nan) for n in names])
        moves.setdefault(spec.name, []).append((u, np.abs(values - base)))
    report = []
    for spec in profile.servos:
        if spec.name not in moves:
            continue
        sweeps = moves[spec.name]
        changes = np.nan_to_num(np.array([change for _, change in sweeps]), nan=0.0)
        largest = changes.max(axis=0)
        best = int(np.argmax(largest / threshold))
        hits = [
            (u, bool((change > threshold).any()))
            for (u, _), change in zip(sweeps, changes, strict=True)
        ]
        below = min((-u for u, hit in hits if hit and u < 0), default=1.0)
        above = min((u for u, hit in hits if hit and u > 0), default=1.0)
        report.append(
            ServoResponse(
                servo=spec.name,
                feature=names[best],
                change=float(largest[best]),
                dead=not any(hit for _, hit in hits),
                below=float(below),
                above=float(above),
            )
        )
    return report
