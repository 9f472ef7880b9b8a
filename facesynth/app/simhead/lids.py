"""The simulated head's eyelids: an upper lid that closes over the eye (``blink_right|left``).

A warp cannot close an eye: the lid's skin would have to come from where the eye is. So a
blink is drawn. Its activation ``a`` (clipped to 0..1) moves each upper-lid landmark that share
of the way to its partner on the lower lid (``a`` = 1: the lids meet); then, in the image:

1. the band the lid has swept (from just above its rest edge down to its new edge) is filled
   with the lid's skin: each column takes the skin a little above the lid's rest edge;
2. the lid's lashes, a dark line, are drawn along its new edge;
3. the iris is clipped by the new opening (:mod:`.renderer` pastes it after this).

The other direction of the same effects (the eye opened wide) is an ordinary warp
(:mod:`.effects`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Final

import cv2
import numpy as np

from facesynth.app.simhead.faces import EYES, LOWER_LIDS, UPPER_LIDS

__all__ = ["BLINK", "close_lids", "closures", "draw_lids"]

#: Blink effects: the eye each closes (0 the performer's right, 1 her left).
BLINK: Final = {"blink_right": 0, "blink_left": 1}
#: The lashes' colour (BGR) and thickness (share of the eye's width).
LASHES: Final = (38, 34, 40)
LASH_WIDTH: Final = 0.07
#: How far above the lid's rest edge its skin is sampled, and how much higher than its rest
#: edge the swept band starts (shares of the eye's width).
SKIN_ABOVE: Final = 0.12
BAND_ABOVE: Final = 0.05
#: Below this activation the lid is left as the warp drew it.
MIN_CLOSURE: Final = 0.02


def closures(activations: Mapping[str, float]) -> dict[int, float]:
    """Per eye, how far its upper lid is closed (0..1), for the eyes closed at all."""
    out = {}
    for name, eye in BLINK.items():
        amount = float(np.clip(activations.get(name, 0.0), 0.0, 1.0))
        if amount >= MIN_CLOSURE:
            out[eye] = amount
    return out


def close_lids(moved: np.ndarray, activations: Mapping[str, float]) -> np.ndarray:
    """The (478, 2) landmarks with each closing upper lid moved toward its lower lid."""
    shut = closures(activations)
    if not shut:
        return moved
    out = moved.copy()
    for eye, amount in shut.items():
        upper, lower = list(UPPER_LIDS[eye]), list(LOWER_LIDS[eye])
        out[upper] = moved[upper] + amount * (moved[lower] - moved[upper])
    return out


def _edge(points: np.ndarray, eye: int) -> np.ndarray:
    """The upper lid's edge from corner to corner (x, y pixels)."""
    contour = EYES[eye]
    return points[[contour[0], *UPPER_LIDS[eye], contour[8]]]


def draw_lids(
    image: np.ndarray, open_points: np.ndarray, shut_points: np.ndarray, amounts: dict[int, float]
) -> None:
    """Draw each closing lid (in place): ``open_points`` are the landmarks before the lids
    closed (:func:`close_lids`), ``shut_points`` after."""
    h, w = image.shape[:2]
    for eye in amounts:
        rest, edge = _edge(open_points, eye), _edge(shut_points, eye)
        width = float(np.linalg.norm(rest[-1] - rest[0]))
        lo = np.floor(np.minimum(rest.min(axis=0), edge.min(axis=0)) - width * 0.3).astype(int)
        hi = np.ceil(np.maximum(rest.max(axis=0), edge.max(axis=0)) + width * 0.3).astype(int)
        lo, hi = lo.clip(0), np.minimum(hi, [w, h])
        rw, rh = int(hi[0] - lo[0]), int(hi[1] - lo[1])
        if rw <= 0 or rh <= 0:
            continue
        raised = rest.copy()
        raised[1:-1, 1] -= BAND_ABOVE * width
        band = np.concatenate([raised, edge[::-1]]) - lo
        mask = np.zeros((rh, rw), np.uint8)
        cv2.fillPoly(mask, [np.round(band * 16).astype(np.int32)], 255, cv2.LINE_AA, 4)
        order = np.argsort(rest[:, 0])
        columns = np.arange(lo[0], hi[0], dtype=np.float64)
        top = np.interp(columns, rest[order, 0], rest[order, 1]) - SKIN_ABOVE * width
        map_x = np.broadcast_to(columns[None, :], (rh, rw)).astype(np.float32)
        map_y = np.broadcast_to(top[None, :], (rh, rw)).astype(np.float32)
        skin = cv2.remap(image, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        roi = image[lo[1] : hi[1], lo[0] : hi[0]]
        alpha = (mask / 255.0)[..., None]
        roi[:] = (roi * (1.0 - alpha) + skin * alpha + 0.5).astype(np.uint8)
        thickness = max(1, round(LASH_WIDTH * width))
        line = np.round((edge - lo) * 16).astype(np.int32)
        cv2.polylines(roi, [line], False, LASHES, thickness, cv2.LINE_AA, 4)
