"""The named features F publishes (``Features.named``) and T's profiles refer to.

Every value is relative to the performer's neutral face and scaled to a calibrated range:
0 at neutral, +1 at the calibrated extreme in the positive direction, -1 at the extreme in the
negative direction (one-sided features rarely go negative). Values beyond the calibrated range
are clamped to ±``SCALED_LIMIT``. ``Features.raw`` holds the same features unscaled (relative to
neutral, in the units below), which is what calibration records.

Default ranges were measured on the bundled performer video with the tracker (the range a
clear expression reaches); a calibration replaces them. Right/left are the performer's own.
Directions: x positive = toward the performer's left, y positive = up, as the performer sees it.

With the ``full`` tracker model F also publishes the 51 ARKit blendshapes of
:mod:`facesynth.runtime.blendshapes` as named features under their own (camelCase) names,
e.g. ``mouthSmileLeft``: the raw value is the model's score (0..1), and like every named
feature it is taken relative to the performer's neutral and scaled to the calibrated range
(default ±0.5 of a score: half the scale from neutral reads ±1). ``_neutral`` is left out.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final

from facesynth.runtime import blendshapes

SCALED_LIMIT: Final = 1.5


@dataclass(frozen=True)
class NamedFeature:
    """One named feature: its unit, what a positive value means, its default raw range."""

    name: str
    unit: str
    positive: str
    default_min: float  # raw value mapped to -1 (<= 0)
    default_max: float  # raw value mapped to +1 (> 0)


def _sided(stem: str, unit: str, positive: str, lo: float, hi: float) -> list[NamedFeature]:
    return [NamedFeature(f"{stem}_{side}", unit, positive, lo, hi) for side in ("right", "left")]


IOD = "inter-ocular distance"

FEATURES: Final[tuple[NamedFeature, ...]] = (
    NamedFeature("head_yaw", "degrees", "head turned toward the performer's left", -30.0, 30.0),
    NamedFeature("head_pitch", "degrees", "head tilted up (chin up)", -20.0, 20.0),
    NamedFeature(
        "head_roll", "degrees", "head tilted toward the performer's left shoulder", -25.0, 25.0
    ),
    NamedFeature(
        "gaze_right_x", "eye widths", "right eye looks toward the performer's left", -0.15, 0.15
    ),
    NamedFeature("gaze_right_y", "eye widths", "right eye looks up", -0.08, 0.08),
    NamedFeature(
        "gaze_left_x", "eye widths", "left eye looks toward the performer's left", -0.15, 0.15
    ),
    NamedFeature("gaze_left_y", "eye widths", "left eye looks up", -0.08, 0.08),
    *_sided(
        "eye_open",
        "lid gap / eye width",
        "eye opened wider than neutral (negative: closing)",
        -0.15,
        0.1,
    ),
    *_sided("brow_raise_inner", IOD, "inner end of the brow raised", -0.03, 0.08),
    *_sided("brow_raise_outer", IOD, "outer end of the brow raised", -0.03, 0.08),
    *_sided("brow_lower", IOD, "brow pulled down and together (frown)", -0.02, 0.06),
    *_sided("lid_tighten", IOD, "lower lid raised", -0.02, 0.04),
    *_sided("cheek_raise", IOD, "cheek raised", -0.02, 0.05),
    *_sided("lip_corner_pull", IOD, "lip corner pulled up and out (smile)", -0.05, 0.12),
    *_sided("lip_corner_depress", IOD, "lip corner pulled down", -0.02, 0.05),
    NamedFeature("jaw_open", IOD, "jaw dropped (chin down)", -0.05, 0.25),
    NamedFeature("lips_part", IOD, "inner lips apart", -0.02, 0.2),
    NamedFeature("lip_pucker", IOD, "mouth narrowed (pucker)", -0.15, 0.08),
)

#: Default raw range of a blendshape feature (scores relative to the neutral's).
BLENDSHAPE_RANGE: Final = (-0.5, 0.5)

BLENDSHAPE_FEATURES: Final[tuple[NamedFeature, ...]] = tuple(
    NamedFeature(
        name, "score (0..1)", f"ARKit blendshape {name} stronger than at neutral", *BLENDSHAPE_RANGE
    )
    for name in blendshapes.SHAPES
)
#: The names of the blendshape features (a profile's ``blendshape = NAME`` must be one).
BLENDSHAPE_NAMES: Final[frozenset[str]] = frozenset(blendshapes.SHAPES)

BY_NAME: Final[dict[str, NamedFeature]] = {
    feature.name: feature for feature in (*FEATURES, *BLENDSHAPE_FEATURES)
}
NAMES: Final[tuple[str, ...]] = tuple(BY_NAME)
#: The features read from the landmarks (every name but the blendshapes').
LANDMARK_NAMES: Final[tuple[str, ...]] = tuple(feature.name for feature in FEATURES)
