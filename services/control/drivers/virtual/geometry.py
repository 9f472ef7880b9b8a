"""The virtual face's geometry: shapes to draw, as a pure function of the ``virtual`` controls.

Both renderers draw only what :func:`face_geometry` returns, in order: the live page (a canvas in
the browser) and the offline video renderer (OpenCV). Neither knows what a brow or a lid is.

Coordinates are in a ``FACE_WIDTH`` x ``FACE_HEIGHT`` box, y down. The face copies the performer:
its right eye (``lid_right``, ``gaze_right_*``) is on the viewer's left, as the performer's right
eye is in an unmirrored camera image. Controls are the ``virtual`` profile's (0..1000): bipolar
controls have 500 at neutral, one-sided ones 0 (see ``facesynth/runtime/profiles/virtual.toml``).
A control that is absent is at neutral; values outside 0..1000 are clamped.

Shapes (``kind``): ``polygon`` (closed, filled and/or stroked), ``polyline`` (open, stroked) and
``circle`` (``points = [[cx, cy]]`` and ``radius``). Colours are ``#rrggbb``; ``None`` = none.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Literal

import msgspec
import numpy as np

FACE_WIDTH = 400.0
FACE_HEIGHT = 480.0

#: Every control the face is drawn from, with its neutral value.
NEUTRAL: dict[str, float] = {
    "brow_right": 500.0,
    "brow_left": 500.0,
    "lid_right": 500.0,
    "lid_left": 500.0,
    "gaze_right_x": 500.0,
    "gaze_right_y": 500.0,
    "gaze_left_x": 500.0,
    "gaze_left_y": 500.0,
    "cheek_right": 0.0,
    "cheek_left": 0.0,
    "lip_corner_right": 500.0,
    "lip_corner_left": 500.0,
    "lower_lip": 0.0,
    "jaw": 0.0,
    "head_yaw": 500.0,
    "head_pitch": 500.0,
    "head_roll": 500.0,
}
#: Controls a profile must have for the face to be drawn (the head pose ones are optional).
FACE_CONTROLS = frozenset(NEUTRAL) - {"head_yaw", "head_pitch", "head_roll"}
#: Degrees of in-plane tilt at ``head_roll`` 0 or 1000 (the roll feature's default range).
ROLL_DEG = 25.0

SKIN = (242, 201, 160)
BLUSH = (232, 120, 130)
OUTLINE = "#8a6248"
BROW = "#4a3020"
LIP = "#b5535f"
MOUTH = "#4a1820"
EYE_WHITE = "#fbfbf8"
IRIS = "#3f7fa8"
PUPIL = "#101418"
LASH = "#2a1a12"

Point = tuple[float, float]


class Shape(msgspec.Struct, kw_only=True, array_like=False):
    """One thing to draw."""

    name: str
    kind: Literal["polygon", "polyline", "circle"]
    points: list[list[float]]
    fill: str | None = None
    stroke: str | None = None
    width: float = 0.0
    radius: float = 0.0


def draws_face(control_names: Iterable[str]) -> bool:
    """Whether a profile with these controls can be drawn as the face (it has all of them)."""
    return set(control_names) >= FACE_CONTROLS


def face_geometry(controls: Mapping[str, float]) -> list[Shape]:
    """The face for these control values, as shapes in drawing order."""
    c = _Controls(controls)
    yaw, pitch = c.bipolar("head_yaw"), c.bipolar("head_pitch")
    roll = math.radians(c.bipolar("head_roll") * ROLL_DEG)
    jaw = c.one_sided("jaw")
    dx, dy = 24.0 * yaw, -16.0 * pitch  # features slide as the head turns and nods
    shapes: list[Shape] = [_head(jaw)]
    for side, cx in (("right", 138.0), ("left", 262.0)):
        cheek = c.one_sided(f"cheek_{side}")
        shapes.append(
            _ellipse(
                f"cheek_{side}",
                cx + dx,
                292.0 + dy - 12.0 * cheek,
                30.0,
                18.0,
                fill=_hex(_mix(SKIN, BLUSH, 0.2 + 0.7 * cheek)),
            )
        )
    for side, cx in (("right", 138.0), ("left", 262.0)):
        shapes.extend(
            _eye(
                side,
                cx + dx,
                200.0 + dy,
                c.bipolar(f"lid_{side}"),
                c.bipolar(f"gaze_{side}_x"),
                c.bipolar(f"gaze_{side}_y"),
            )
        )
        shapes.append(_brow(side, cx + dx, 150.0 + dy, c.bipolar(f"brow_{side}")))
    shapes.append(_nose(200.0 + 1.4 * dx, 0.0 + dy))
    shapes.extend(
        _mouth(
            200.0 + dx,
            330.0 + dy,
            c.bipolar("lip_corner_right"),
            c.bipolar("lip_corner_left"),
            c.one_sided("lower_lip"),
            jaw,
        )
    )
    _finish(shapes, roll, (FACE_WIDTH / 2, 300.0))
    return shapes


class _Controls:
    """Control values by name, clamped to 0..1000, neutral when absent or not a number."""

    def __init__(self, values: Mapping[str, float]) -> None:
        self.values = values

    def _value(self, name: str) -> float:
        value = self.values.get(name, NEUTRAL[name])
        if not isinstance(value, int | float) or not math.isfinite(value):
            value = NEUTRAL[name]
        return min(1000.0, max(0.0, float(value)))

    def bipolar(self, name: str) -> float:
        """-1 (at 0) .. 0 (at 500) .. +1 (at 1000)."""
        return (self._value(name) - 500.0) / 500.0

    def one_sided(self, name: str) -> float:
        """0 (at 0) .. 1 (at 1000)."""
        return self._value(name) / 1000.0


def _head(jaw: float) -> Shape:
    """The head outline: an egg whose chin drops with the jaw."""
    cx, cy, rx, top, bottom = FACE_WIDTH / 2, 235.0, 150.0, 185.0, 180.0 + 40.0 * jaw
    points = []
    for i in range(56):
        a = 2 * math.pi * i / 56
        s = math.sin(a)
        ry = bottom if s > 0 else top
        narrow = 1.0 - 0.18 * max(0.0, s) ** 2  # a narrower chin
        points.append((cx + rx * math.cos(a) * narrow, cy + ry * s))
    return _shape("head", "polygon", points, fill=_hex(SKIN), stroke=OUTLINE, width=3.0)


def _eye(side: str, cx: float, cy: float, lid: float, gx: float, gy: float) -> list[Shape]:
    """White, iris, pupil, then the skin of the lids over them and the lash line."""
    half = 36.0
    lower_h = 15.0
    # Upper lid height above the corners: closed 0, neutral 20, wide open 30.
    upper_h = 20.0 + (10.0 * lid if lid >= 0 else 20.0 * lid)
    white = _lid_curve(cx, cy, half, -31.0) + _lid_curve(cx, cy, half, lower_h)[::-1]
    iris_x = cx + 17.0 * gx
    iris_y = cy - 4.0 - 9.0 * gy
    upper = _lid_curve(cx, cy, half, -upper_h)
    above = _lid_curve(cx, cy, half + 6.0, -50.0)
    below = _lid_curve(cx, cy, half + 6.0, lower_h + 22.0)
    lower = _lid_curve(cx, cy, half, lower_h)
    skin = _hex(SKIN)
    return [
        _shape(f"eye_{side}", "polygon", white, fill=EYE_WHITE),
        _shape(f"iris_{side}", "circle", [(iris_x, iris_y)], fill=IRIS, radius=13.0),
        _shape(f"pupil_{side}", "circle", [(iris_x, iris_y)], fill=PUPIL, radius=5.5),
        _shape(f"upper_lid_{side}", "polygon", upper + above[::-1], fill=skin),
        _shape(f"lower_lid_{side}", "polygon", lower + below[::-1], fill=skin),
        _shape(f"lash_{side}", "polyline", upper, stroke=LASH, width=3.0),
    ]


def _lid_curve(cx: float, cy: float, half: float, height: float, n: int = 11) -> list[Point]:
    """A lid from the viewer's-left corner to the right one, ``height`` at the middle (y down)."""
    points = []
    for i in range(n):
        t = -1.0 + 2.0 * i / (n - 1)
        points.append((cx + half * t, cy + height * (1.0 - t * t) * (1.0 - 0.15 * t)))
    return points


def _brow(side: str, cx: float, cy: float, brow: float) -> Shape:
    """A thick arc: raised and arched above neutral, lowered with the inner end down below."""
    inner = 1.0 if side == "right" else -1.0  # +x points to the inner end of the right brow
    lift = 22.0 * brow if brow >= 0 else 12.0 * brow
    arch = 10.0 + 6.0 * max(0.0, brow)
    points = []
    for i in range(7):
        t = -1.0 + 2.0 * i / 6  # -1 at the viewer's left end
        toward_inner = (t * inner + 1.0) / 2.0  # 0 outer end .. 1 inner end
        frown = 20.0 * max(0.0, -brow) * toward_inner
        points.append((cx + 42.0 * t, cy - lift - arch * (1.0 - t * t) + frown))
    return _shape(f"brow_{side}", "polyline", points, stroke=BROW, width=9.0)


def _nose(cx: float, dy: float) -> Shape:
    points = [(cx - 2.0, 212.0 + dy), (cx - 14.0, 274.0 + dy), (cx + 2.0, 281.0 + dy)]
    return _shape("nose", "polyline", points, stroke=OUTLINE, width=3.0)


def _mouth(
    cx: float, cy: float, corner_r: float, corner_l: float, lower_lip: float, jaw: float
) -> list[Shape]:
    """Lips from the corners (smile up, frown down) with the opening of the lips and jaw."""
    half = 56.0
    right_y = cy - 16.0 * corner_r  # the right corner is on the viewer's left
    left_y = cy - 16.0 * corner_l
    opening = 2.0 + 24.0 * lower_lip + 38.0 * jaw
    upper = _lip_curve(cx, half, right_y, left_y, cy - 3.0)
    lower = _lip_curve(cx, half, right_y, left_y, cy + opening)
    return [
        _shape("mouth", "polygon", upper + lower[::-1], fill=MOUTH),
        _shape("upper_lip", "polyline", upper, stroke=LIP, width=6.0),
        _shape("lower_lip", "polyline", lower, stroke=LIP, width=7.0),
    ]


def _lip_curve(
    cx: float, half: float, right_y: float, left_y: float, middle_y: float, n: int = 13
) -> list[Point]:
    """Through both corners and ``middle_y`` at the centre."""
    points = []
    for i in range(n):
        t = -1.0 + 2.0 * i / (n - 1)
        base = right_y + (left_y - right_y) * (t + 1.0) / 2.0
        mid_base = (right_y + left_y) / 2.0
        points.append((cx + half * t, base + (middle_y - mid_base) * (1.0 - t * t)))
    return points


def _ellipse(name: str, cx: float, cy: float, rx: float, ry: float, *, fill: str) -> Shape:
    points = [
        (cx + rx * math.cos(2 * math.pi * i / 18), cy + ry * math.sin(2 * math.pi * i / 18))
        for i in range(18)
    ]
    return _shape(name, "polygon", points, fill=fill)


def _finish(shapes: list[Shape], angle: float, centre: Point) -> None:
    """Turn every point by ``angle`` radians about ``centre`` (positive: clockwise on screen)
    and round to 0.1, in one pass over all shapes (in place)."""
    points = np.array([p for shape in shapes for p in shape.points], dtype=np.float64)
    if angle:
        cos, sin = math.cos(angle), math.sin(angle)
        offset = points - centre
        points = (
            np.column_stack(
                (offset[:, 0] * cos - offset[:, 1] * sin, offset[:, 0] * sin + offset[:, 1] * cos)
            )
            + centre
        )
    flat = np.round(points, 1).tolist()
    start = 0
    for shape in shapes:
        count = len(shape.points)
        shape.points = flat[start : start + count]
        start += count


def _shape(
    name: str,
    kind: Literal["polygon", "polyline", "circle"],
    points: Sequence[Point],
    *,
    fill: str | None = None,
    stroke: str | None = None,
    width: float = 0.0,
    radius: float = 0.0,
) -> Shape:
    return Shape(
        name=name,
        kind=kind,
        points=points,  # type: ignore[arg-type] # tuples until _finish makes them lists
        fill=fill,
        stroke=stroke,
        width=width,
        radius=radius,
    )


def _mix(a: tuple[int, int, int], b: tuple[int, int, int], t: float) -> tuple[int, int, int]:
    t = min(1.0, max(0.0, t))
    return (
        round(a[0] + (b[0] - a[0]) * t),
        round(a[1] + (b[1] - a[1]) * t),
        round(a[2] + (b[2] - a[2]) * t),
    )


def _hex(rgb: tuple[int, int, int]) -> str:
    return "#{:02x}{:02x}{:02x}".format(*rgb)
