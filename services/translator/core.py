"""Translator T, pure core: features to servo positions (the paper's section 2.2.3).

Per servo: average the movement (delta from neutral) of its point group; map it linearly from
the face range [face_min, 0, face_max] onto [min_us, neutral_us, max_us] (swapped for reversed
servos); clamp to the servo's limits. While no face is tracked, or the neutral is not known yet,
every servo sits at neutral.
"""

from __future__ import annotations

import numpy as np

from facesynth.calibration import Calibration
from facesynth.landmarks import MIRROR, N_IBUG
from facesynth.profiles import Profile, ServoSpec
from schemas.messages import Features, ServoCommands


class TranslationError(ValueError):
    """Features that cannot be translated with this profile."""


def interpolate(movement: float, face_min: float, face_max: float, spec: ServoSpec) -> float:
    """Servo position for a group movement: piecewise linear through neutral, clamped."""
    if spec.reversed:
        movement = -movement
        face_min, face_max = -face_max, -face_min
    if movement >= 0:
        fraction = min(movement / face_max, 1.0)
        position = spec.neutral_us + fraction * (spec.max_us - spec.neutral_us)
    else:
        fraction = min(movement / face_min, 1.0)
        position = spec.neutral_us - fraction * (spec.neutral_us - spec.min_us)
    return clamp(position, spec)


def clamp(position: float, spec: ServoSpec) -> float:
    """``position`` limited to the servo's [min_us, max_us]."""
    return min(max(position, spec.min_us), spec.max_us)


class Translator:
    """Features messages in, ServoCommands messages out, for one profile."""

    def __init__(self, profile: Profile, calibration: Calibration | None = None) -> None:
        self.profile = profile
        self._groups = [np.asarray(spec.points, dtype=np.intp) for spec in profile.servos]
        self._ranges: list[tuple[float, float]] = []
        for spec, group in zip(profile.servos, self._groups, strict=True):
            if calibration is None:
                self._ranges.append((spec.face_min, spec.face_max))
                continue
            source = MIRROR[group] if profile.mirror else group
            low = float(np.mean(np.asarray(calibration.delta_min)[source]))
            high = float(np.mean(np.asarray(calibration.delta_max)[source]))
            # A point group that did not move during calibration keeps the profile default.
            self._ranges.append(
                (low if low < 0 else spec.face_min, high if high > 0 else spec.face_max)
            )

    def neutral(self) -> dict[str, float]:
        """Every servo at neutral."""
        return self.profile.neutral_positions()

    def positions(self, deltas: np.ndarray) -> dict[str, float]:
        """Servo positions for 68 deltas from neutral."""
        if deltas.shape != (N_IBUG,):
            raise TranslationError(f"need {N_IBUG} deltas, got {deltas.shape[0]}")
        if self.profile.mirror:
            deltas = deltas[MIRROR]
        out = {}
        for spec, group, (low, high) in zip(
            self.profile.servos, self._groups, self._ranges, strict=True
        ):
            out[spec.name] = interpolate(float(deltas[group].mean()), low, high, spec)
        return out

    def translate(self, features: Features) -> ServoCommands:
        """Servo commands for one frame's features."""
        tracking = features.face and features.neutral_ready and bool(features.deltas)
        if tracking:
            positions = self.positions(np.asarray(features.deltas, dtype=np.float64))
        else:
            positions = self.neutral()
        return ServoCommands(
            seq=features.seq,
            t_capture_ns=features.t_capture_ns,
            t_media_ns=features.t_media_ns,
            face=features.face,
            profile=self.profile.name,
            positions=positions,
        )
