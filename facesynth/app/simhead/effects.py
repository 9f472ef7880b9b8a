"""The simulated head's primitive effects: what each one does to the face's landmarks.

An effect is a signed activation (0 = rest). Each direction of an effect has its own shape:
``plus`` for positive activations, ``minus`` for negative ones (None: that direction does
nothing), each a (478, 2) landmark displacement in the face frame at activation ±1 (x toward
the performer's left, y up, unit = the inter-ocular distance, IOD; see
:class:`facesynth.app.simhead.faces.Face`). Gaze effects move an iris instead (eye
widths at ±1), a blink's closing is drawn (:mod:`.lids`) and the neck turns the whole head
(:mod:`.neck`). Right/left are the performer's own (the face's right is the image's left).

The shapes are built from the landmark groups of :mod:`facesynth.app.simhead.faces`
with a Gaussian falloff around the moving features, so the skin around them follows.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Final

import numpy as np

from facesynth.app.simhead.faces import (
    INNER_BROW,
    LEFT_BROW,
    LEFT_EYE,
    LIP_CORNERS,
    LOWER_INNER_LIP,
    LOWER_LIDS,
    RIGHT_BROW,
    RIGHT_EYE,
    UPPER_INNER_LIP,
    UPPER_LIDS,
    Face,
    falloff,
)

__all__ = ["EFFECTS", "GAZE", "MOUTH_OPENING", "EffectShape", "effect_shapes"]

#: Gaze effects: (eye index 0 right / 1 left, axis 0 x / 1 y) per effect.
GAZE: Final = {
    "gaze_right_x": (0, 0),
    "gaze_right_y": (0, 1),
    "gaze_left_x": (1, 0),
    "gaze_left_y": (1, 1),
}
#: Effects whose positive direction opens the mouth (painted dark between the inner lips).
MOUTH_OPENING: Final = (
    "jaw",
    "lower_lip_right",
    "lower_lip_left",
    "upper_lip_right",
    "upper_lip_left",
)
#: Iris travel at a gaze activation of ±1, in eye widths (x, y).
GAZE_RANGE: Final = (0.2, 0.11)

SIDES: Final = ("right", "left")
# Mesh vertices of the infraorbital cheek (as services.features.expressions reads it) and of
# the upper lip's outer edge, per side.
CHEEKS: Final = ((50, 101, 117, 118, 123, 205, 36), (280, 330, 346, 347, 352, 425, 266))
UPPER_LIP: Final = ((37, 39, 40, 185, 80, 81), (267, 269, 270, 409, 310, 311))
LOWER_LIP: Final = ((84, 181, 91, 146, 87, 178, 88), (314, 405, 321, 375, 317, 402, 318))
BROWS: Final = (RIGHT_BROW, LEFT_BROW)
EYES: Final = (RIGHT_EYE, LEFT_EYE)
OUTWARD: Final = (-1.0, 1.0)  # x sign of "away from the midline", per side


@dataclass(frozen=True)
class EffectShape:
    """One primitive effect: its landmark moves per direction (see the module doc)."""

    name: str
    plus: np.ndarray | None
    minus: np.ndarray | None


def _still_eyes(move: np.ndarray) -> np.ndarray:
    move[list(RIGHT_EYE) + list(LEFT_EYE) + list(range(468, 478))] = 0.0
    return move


def _shift(local: np.ndarray, at: list[int], dx: float, dy: float, sigma: float) -> np.ndarray:
    weight = falloff(local, local[at], sigma)
    move = np.zeros((478, 2))
    move[:, 0] = dx * weight
    move[:, 1] = dy * weight
    return move


def _half(local: np.ndarray, side: int) -> np.ndarray:
    """1 on the side's half of the face, fading across the midline over 0.15 IOD."""
    midline = float(local[[1, 4, 168], 0].mean())
    x = OUTWARD[side] * (local[:, 0] - midline)
    half: np.ndarray = np.clip(0.5 + x / 0.15, 0.0, 1.0)
    return half


def _brow(face: Face, side: int) -> tuple[np.ndarray, np.ndarray]:
    local = face.local()
    brow = list(BROWS[side])
    up = _still_eyes(_shift(local, brow, 0.0, 0.075, 0.09))
    down = _still_eyes(_shift(local, brow, 0.0, -0.06, 0.08))
    return up, down


def _brow_inner(face: Face) -> tuple[np.ndarray, np.ndarray]:
    local = face.local()
    inner = [i for group in INNER_BROW for i in group]
    up = _still_eyes(_shift(local, inner, 0.0, 0.07, 0.07))
    frown = _still_eyes(_shift(local, list(RIGHT_BROW) + list(LEFT_BROW), 0.0, -0.055, 0.08))
    for side, group in enumerate(INNER_BROW):
        frown[:, 0] += -OUTWARD[side] * 0.045 * falloff(local, local[list(group)], 0.07)
    return up, frown


def _lids(face: Face, side: int) -> tuple[np.ndarray, np.ndarray]:
    width = float(np.linalg.norm(face.points[133, :2] - face.points[33, :2])) / face.iod
    wide, closing = np.zeros((478, 2)), np.zeros((478, 2))
    wide[list(UPPER_LIDS[side]), 1] = 0.2 * width
    wide[list(LOWER_LIDS[side]), 1] = -0.025 * width
    closing[list(UPPER_LIDS[side]), 1] = -0.13 * width
    closing[list(LOWER_LIDS[side]), 1] = 0.05 * width
    return wide, closing


def _cheek(face: Face, side: int) -> tuple[np.ndarray, None]:
    """Raised: the infraorbital cheek up, pushing the lower lid up (a squint from below) and
    lifting the lip corner a little (a cheek cannot be pulled below its rest)."""
    local = face.local()
    raised = _shift(local, list(CHEEKS[side]), 0.0, 0.12, 0.12)
    raised[list(EYES[side]), :] = 0.0
    raised[list(range(468, 478)), :] = 0.0
    width = float(np.linalg.norm(face.points[133, :2] - face.points[33, :2])) / face.iod
    raised[list(LOWER_LIDS[side]), 1] = 0.2 * width
    raised[LIP_CORNERS[side], 1] = max(raised[LIP_CORNERS[side], 1], 0.02)
    return raised, None


def _upper_lip(face: Face, side: int) -> tuple[np.ndarray, None]:
    """Raised: the upper lip's half lifted off the lower lip (the mouth opens a little)."""
    local = face.local()
    half = _half(local, side)[:, None]
    raised = _shift(local, list(UPPER_LIP[side]), 0.0, 0.06, 0.07) * half
    raised[list(UPPER_INNER_LIP), 1] = 0.06 * half[list(UPPER_INNER_LIP), 0]
    raised[list(LOWER_INNER_LIP), :] = 0.0
    raised[list(LIP_CORNERS), :] *= 0.3
    return _still_eyes(raised), None


def _hinge(face: Face, drop: float) -> np.ndarray:
    """The jaw dropped by ``drop`` IOD: the lower inner lip and everything below it by the
    full amount, the lip corners by half (they move with the mouth's centre), the upper lip
    and everything above the mouth not at all."""
    local = face.local()
    mouth_y = float(local[[13, 14], 1].mean())
    depth = np.clip((mouth_y - local[:, 1]) / 0.03, 0.0, 1.0)
    move = np.zeros((478, 2))
    move[:, 1] = -drop * depth
    move[list(LOWER_INNER_LIP), 1] = -drop
    move[list(UPPER_INNER_LIP), 1] = 0.0
    for corner in (*LIP_CORNERS, LOWER_INNER_LIP[0], LOWER_INNER_LIP[-1]):
        move[corner, 1] = -0.5 * drop
    return _still_eyes(move)


def _jaw(face: Face) -> tuple[np.ndarray, np.ndarray]:
    return _hinge(face, 0.24), _hinge(face, -0.015)


def _lip_corner(face: Face, side: int) -> tuple[np.ndarray, np.ndarray]:
    local = face.local()
    corner = [LIP_CORNERS[side]]
    pull = _still_eyes(_shift(local, corner, OUTWARD[side] * 0.11, 0.1, 0.12))
    depress = _still_eyes(_shift(local, corner, OUTWARD[side] * 0.02, -0.09, 0.1))
    return pull, depress


def _lower_lip(face: Face, side: int) -> tuple[np.ndarray, None]:
    """Lowered: the lower lip's half pulled down off the upper lip (the mouth opens)."""
    local = face.local()
    lip = list(LOWER_LIP[side])
    down = _shift(local, lip, 0.0, -0.09, 0.07) * _half(local, side)[:, None]
    down[list(UPPER_INNER_LIP), :] = 0.0
    down[list(LIP_CORNERS), :] *= 0.3
    return _still_eyes(down), None


def _pucker(face: Face) -> tuple[np.ndarray, np.ndarray]:
    local = face.local()
    narrow, wide = np.zeros((478, 2)), np.zeros((478, 2))
    for side, corner in enumerate(LIP_CORNERS):
        narrow += _shift(local, [corner], -OUTWARD[side] * 0.07, 0.0, 0.1)
        wide += _shift(local, [corner], OUTWARD[side] * 0.05, -0.005, 0.1)
    return _still_eyes(narrow), _still_eyes(wide)


def _sided(
    stem: str, build: Callable[[Face, int], tuple[np.ndarray | None, np.ndarray | None]]
) -> dict[str, Callable[[Face], tuple[np.ndarray | None, np.ndarray | None]]]:
    return {f"{stem}_{s}": functools.partial(_on_side, build, i) for i, s in enumerate(SIDES)}


def _on_side(
    build: Callable[[Face, int], tuple[np.ndarray | None, np.ndarray | None]], side: int, face: Face
) -> tuple[np.ndarray | None, np.ndarray | None]:
    return build(face, side)


def _none(face: Face) -> tuple[None, None]:
    return None, None  # gaze, neck: the renderer moves the iris, the whole head


def _blink(face: Face, side: int) -> tuple[None, np.ndarray]:
    """Closing: drawn by the renderer (:mod:`.lids`); the other way the eye opens wide."""
    return None, _lids(face, side)[0]


_BUILDERS: Final[dict[str, Callable[[Face], tuple[np.ndarray | None, np.ndarray | None]]]] = {
    **_sided("brow", _brow),
    "brow_inner": _brow_inner,
    **_sided("lids", _lids),
    **dict.fromkeys(GAZE, _none),
    **_sided("cheek", _cheek),
    **_sided("upper_lip", _upper_lip),
    "jaw": _jaw,
    **_sided("lip_corner", _lip_corner),
    **_sided("lower_lip", _lower_lip),
    "lip_pucker": _pucker,
    **_sided("blink", _blink),
    "neck_yaw": _none,
    "neck_pitch": _none,
}

#: Every primitive effect, in a fixed order.
EFFECTS: Final = tuple(_BUILDERS)


def effect_shapes(face: Face) -> list[EffectShape]:
    """Every effect's landmark moves on ``face`` (IOD, face frame), in :data:`EFFECTS` order."""
    out = []
    for name in EFFECTS:
        plus, minus = _BUILDERS[name](face)
        out.append(EffectShape(name, plus, minus))
    return out
