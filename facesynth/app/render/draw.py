"""OpenCV drawing for the side-by-side video: the face's shapes, landmarks, servo bars, panels.

The face is drawn from :func:`services.control.drivers.virtual.geometry.face_geometry`, the
same shapes the live page draws on its canvas; this module only knows how to draw a shape.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from facesynth.runtime.profiles import Profile
from facesynth.services.control.drivers.virtual.geometry import FACE_HEIGHT, FACE_WIDTH, Shape

BACKGROUND = (40, 34, 30)  # BGR
TEXT = (225, 225, 225)
BAR = (96, 176, 232)
BAR_BACK = (70, 62, 56)
NEUTRAL_MARK = (240, 240, 240)
LANDMARK = (80, 255, 120)
NO_FACE = (60, 60, 230)
SHIFT = 4  # sub-pixel bits for cv2 drawing
SCALE = 1 << SHIFT


def _bgr(colour: str) -> tuple[int, int, int]:
    value = int(colour[1:], 16)
    return (value & 0xFF, (value >> 8) & 0xFF, value >> 16)


def draw_shapes(canvas: np.ndarray, shapes: Sequence[Shape]) -> None:
    """Draw the face's shapes, fitted and centred in ``canvas`` (in place)."""
    height, width = canvas.shape[:2]
    scale = min(width / FACE_WIDTH, height / FACE_HEIGHT)
    ox = (width - FACE_WIDTH * scale) / 2
    oy = (height - FACE_HEIGHT * scale) / 2

    def fixed(points: list[list[float]]) -> np.ndarray:
        array = np.asarray(points, dtype=np.float64) * scale + (ox, oy)
        return np.round(array * SCALE).astype(np.int32)

    for shape in shapes:
        points = fixed(shape.points)
        thickness = max(1, round(shape.width * scale))
        if shape.kind == "circle":
            centre = (int(points[0][0]), int(points[0][1]))
            radius = round(shape.radius * scale * SCALE)
            if shape.fill:
                cv2.circle(canvas, centre, radius, _bgr(shape.fill), -1, cv2.LINE_AA, SHIFT)
            if shape.stroke:
                cv2.circle(
                    canvas, centre, radius, _bgr(shape.stroke), thickness, cv2.LINE_AA, SHIFT
                )
            continue
        closed = shape.kind == "polygon"
        if closed and shape.fill:
            cv2.fillPoly(canvas, [points], _bgr(shape.fill), cv2.LINE_AA, SHIFT)
        if shape.stroke:
            cv2.polylines(
                canvas, [points], closed, _bgr(shape.stroke), thickness, cv2.LINE_AA, SHIFT
            )


def draw_landmarks(image: np.ndarray, points: np.ndarray | None) -> None:
    """Dots on the tracked 68 points (in place); a red frame when no face was found."""
    if points is None:
        h, w = image.shape[:2]
        cv2.rectangle(image, (1, 1), (w - 2, h - 2), NO_FACE, 3)
        _label(image, "no face", (10, 24), NO_FACE)
        return
    radius = max(1, round(image.shape[0] / 240))
    for x, y in np.asarray(points, dtype=np.float64)[:, :2]:
        cv2.circle(
            image,
            (round(x * SCALE), round(y * SCALE)),
            radius * SCALE,
            LANDMARK,
            -1,
            cv2.LINE_AA,
            SHIFT,
        )


@dataclass(frozen=True)
class BarSpec:
    """One bar: a control's name and its range."""

    name: str
    low: float
    neutral: float
    high: float


def bar_specs(profile: Profile) -> list[BarSpec]:
    """The bars of a profile's servos, in channel order."""
    return [
        BarSpec(s.name, s.min_us, s.neutral_us, s.max_us)
        for s in sorted(profile.servos, key=lambda s: s.channel)
    ]


def draw_bars(
    canvas: np.ndarray, title: str, bars: Sequence[BarSpec], values: Mapping[str, float]
) -> None:
    """Horizontal bars, one per control, with the neutral marked (in place)."""
    height, width = canvas.shape[:2]
    draw_title(canvas, title)
    if not bars:
        return
    top, row = 28, max(8, (height - 34) // len(bars))
    font = min(0.38, row / 40)
    x0, x1 = 8 + int(width * 0.42), width - 10
    for i, bar in enumerate(bars):
        y = top + i * row
        _label(canvas, bar.name, (8, y + int(row * 0.7)), TEXT, font)
        span = (bar.high - bar.low) or 1.0
        value = min(bar.high, max(bar.low, float(values.get(bar.name, bar.neutral))))
        fraction = (value - bar.low) / span
        neutral = (bar.neutral - bar.low) / span
        bar_h = max(3, int(row * 0.6))
        cv2.rectangle(canvas, (x0, y + 2), (x1, y + 2 + bar_h), BAR_BACK, -1)
        a, b = sorted((neutral, fraction))
        cv2.rectangle(
            canvas,
            (x0 + int(a * (x1 - x0)), y + 2),
            (x0 + int(b * (x1 - x0)) + 1, y + 2 + bar_h),
            BAR,
            -1,
        )
        xn = x0 + int(neutral * (x1 - x0))
        cv2.line(canvas, (xn, y), (xn, y + 4 + bar_h), NEUTRAL_MARK, 1)


def draw_title(canvas: np.ndarray, title: str) -> None:
    """A panel's name in its top-left corner (in place)."""
    _label(canvas, title, (8, 18), TEXT, 0.45)


def _label(
    image: np.ndarray,
    text: str,
    origin: tuple[int, int],
    colour: tuple[int, int, int],
    scale: float = 0.6,
) -> None:
    cv2.putText(image, text, origin, cv2.FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv2.LINE_AA)


def panel(height: int, width: int) -> np.ndarray:
    """An empty panel."""
    canvas = np.empty((height, width, 3), dtype=np.uint8)
    canvas[:] = BACKGROUND
    return canvas
