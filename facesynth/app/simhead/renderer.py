"""The simulated head's renderer: the bundled photo moved by effect activations, in a few ms.

:mod:`facesynth.app.simhead.faces` warps a face with a Nadaraya-Watson field computed
per pixel per frame (100-600 ms). Here the field is linear in the activations: at start-up each
direction of each effect (:mod:`.effects`) gets one dense displacement field — the
Gaussian-weighted mean of the landmarks' moves (weights at their rest places, ``sigma`` =
0.035 IOD, with a zero-move background weight so that far from the face nothing moves). A frame
is then:

1. the forward field ``f`` = the activation-weighted sum of the fields (one matrix product);
2. the backward map, inverted with one fixed-point step: source(p) = p - f(p - f(p));
3. one ``cv2.remap`` of the photo with its irises painted out;
4. the mouth between the (moved) inner lips painted dark when an effect opens it;
5. closing upper lids drawn over the eyes (:mod:`.lids`);
6. each iris pasted at its new centre (the moved eye plus the gaze), clipped by the moved lids;
7. the whole head turned by the neck (:mod:`.neck`), when a head has one.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from functools import cache
from typing import Final

import cv2
import numpy as np

from facesynth.app.simhead.faces import (
    EYES,
    IRIS_CENTRES,
    LOWER_INNER_LIP,
    UPPER_INNER_LIP,
    Face,
    iris_radius,
    remove_irises,
)

from .effects import GAZE, GAZE_RANGE, MOUTH_OPENING, EffectShape, effect_shapes
from .lids import BLINK, close_lids, closures, draw_lids
from .neck import NECK_DEGREES, Neck
from .photo import bundled_face

__all__ = ["Renderer", "default_renderer"]

#: Width of the warp's Gaussian weights, in IOD (as faces.py uses).
SIGMA_IOD: Final = 0.05
#: Background weight of the field (a point 3 sigma from every landmark).
BACKGROUND: Final = float(np.exp(-4.5))
#: The inside of an opened mouth (BGR): dark, a little red.
MOUTH: Final = (26, 22, 52)
#: Pixels per block when the fields are computed (memory: block x 468 x 8 bytes).
BLOCK: Final = 4096


class Renderer:
    """Renders a face under effect activations (see the module doc).

    ``render(activations)`` takes ``{effect name: activation}`` (missing = 0; unknown names
    are ignored) and returns a new BGR image the size of the face's photo.
    """

    def __init__(self, face: Face, shapes: Sequence[EffectShape]) -> None:
        self.face = face
        self.names = tuple(shape.name for shape in shapes)
        h, w = face.image.shape[:2]
        self._base = remove_irises(face.image, face.points)
        columns: list[tuple[int, float]] = []  # (effect index, direction) per field
        moves: list[np.ndarray] = []  # the 478 landmarks' pixel moves per field
        for i, shape in enumerate(shapes):
            for direction, move in ((1.0, shape.plus), (-1.0, shape.minus)):
                if move is not None and np.abs(move).max() > 0:
                    columns.append((i, direction))
                    moves.append(face.to_image(move[:, 0], move[:, 1]))
        self._columns = columns
        self._moves = np.array(moves, np.float64).reshape(len(moves), 478, 2)
        sigma = SIGMA_IOD * face.iod
        anchors = face.points[:468, :2]
        lo = np.floor(anchors.min(axis=0) - 4 * sigma).astype(int).clip(0, [w - 1, h - 1])
        hi = np.ceil(anchors.max(axis=0) + 4 * sigma).astype(int).clip(0, [w - 1, h - 1])
        self._box = (int(lo[1]), int(hi[1]) + 1, int(lo[0]), int(hi[0]) + 1)  # y0, y1, x0, x1
        self._fields = self._dense_fields(anchors, sigma)
        y0, y1, x0, x1 = self._box
        xs, ys = np.meshgrid(
            np.arange(x0, x1, dtype=np.float32), np.arange(y0, y1, dtype=np.float32)
        )
        self._box_grid = np.stack([xs, ys], axis=2)  # pixel coordinates over the box
        self._gaze = {name: GAZE[name] for name in self.names if name in GAZE}
        self._irises = [self._iris(eye) for eye in range(2)]
        self._drawn = frozenset(name for name in self.names if name in BLINK)
        necks = [name for name in self.names if name in NECK_DEGREES]
        self._neck = Neck(face) if necks else None
        self._necks = frozenset(necks)

    def _dense_fields(self, anchors: np.ndarray, sigma: float) -> np.ndarray:
        """(fields, box pixels x 2) float32: every field over the face's box."""
        y0, y1, x0, x1 = self._box
        xs, ys = np.meshgrid(np.arange(x0, x1), np.arange(y0, y1))
        grid = np.stack([xs.ravel(), ys.ravel()], axis=1).astype(np.float64)
        shifts = self._moves[:, :468, :].transpose(1, 0, 2).reshape(468, -1)  # (468, K*2)
        out = np.empty((len(grid), shifts.shape[1]), np.float64)
        for start in range(0, len(grid), BLOCK):
            block = grid[start : start + BLOCK]
            d2 = ((block[:, None, :] - anchors[None, :, :]) ** 2).sum(axis=2)
            weight = np.exp(-d2 / (2.0 * sigma * sigma))
            out[start : start + BLOCK] = (weight @ shifts) / (BACKGROUND + weight.sum(axis=1))[
                :, None
            ]
        k = len(self._columns)
        fields = out.reshape(len(grid), k, 2).transpose(1, 0, 2).reshape(k, -1)
        return np.ascontiguousarray(fields, np.float32)

    def _iris(self, eye: int) -> tuple[np.ndarray, float]:
        """(centre, radius) of iris ``eye`` in the photo (pixels)."""
        points = self.face.points
        return points[IRIS_CENTRES[eye], :2].copy(), iris_radius(points, eye)

    def coefficients(self, activations: Mapping[str, float]) -> np.ndarray:
        """Per field, its weight under ``activations`` (the activation on its side, else 0)."""
        weights = np.zeros(len(self._columns))
        for k, (i, direction) in enumerate(self._columns):
            value = activations.get(self.names[i], 0.0) * direction
            if value > 0:
                weights[k] = value
        return weights

    def _only(self, activations: Mapping[str, float], names: frozenset[str]) -> dict[str, float]:
        return {name: value for name, value in activations.items() if name in names}

    def landmarks(self, activations: Mapping[str, float]) -> np.ndarray:
        """The photo's 478 landmarks moved by ``activations`` (x, y pixels)."""
        weights = self.coefficients(activations)
        moved: np.ndarray = self.face.points[:, :2] + np.tensordot(weights, self._moves, 1)
        moved = close_lids(moved, self._only(activations, self._drawn))
        if self._neck is not None:
            moved = self._neck.landmarks(moved, self._only(activations, self._necks))
        return moved

    def render(self, activations: Mapping[str, float]) -> np.ndarray:
        """The face under ``activations`` (BGR, a new array)."""
        weights = self.coefficients(activations)
        image = self._base.copy()
        if weights.any():
            y0, y1, x0, x1 = self._box
            # a weighted sum of the active fields, element-wise (a BLAS product may wait on
            # threads of a busy machine: measured 0.2 ms idle, 12-15 ms under load)
            flat = np.zeros(self._fields.shape[1], np.float32)
            for k in np.flatnonzero(weights):
                flat += np.float32(weights[k]) * self._fields[k]
            field = flat.reshape(y1 - y0, x1 - x0, 2)
            # the forward field at p - f(p), sampled in the box (zero outside it)
            first = self._box_grid - field
            back = cv2.remap(
                field,
                first[..., 0] - x0,
                first[..., 1] - y0,
                cv2.INTER_LINEAR,
                borderMode=cv2.BORDER_CONSTANT,
            )
            source = self._box_grid - back
            image[y0:y1, x0:x1] = cv2.remap(
                self._base,
                source[..., 0],
                source[..., 1],
                cv2.INTER_LINEAR,
                borderMode=cv2.BORDER_REPLICATE,
            )
        moved = self.face.points[:, :2] + np.tensordot(weights, self._moves, 1)
        if any(activations.get(name, 0.0) > 0.02 for name in MOUTH_OPENING):
            upper, lower = moved[list(UPPER_INNER_LIP)], moved[list(LOWER_INNER_LIP)]
            lips = np.concatenate([upper, lower[::-1]])
            cv2.fillPoly(image, [np.round(lips * 16).astype(np.int32)], MOUTH, cv2.LINE_AA, 4)
        blinks = self._only(activations, self._drawn)
        shut = closures(blinks)
        if shut:
            closed = close_lids(moved, blinks)
            draw_lids(image, moved, closed, shut)
            moved = closed
        for eye in range(2):
            self._paste_iris(image, eye, moved, activations)
        if self._neck is not None:
            image = self._neck.turn(image, self._only(activations, self._necks))
        return image

    def _paste_iris(
        self, image: np.ndarray, eye: int, moved: np.ndarray, activations: Mapping[str, float]
    ) -> None:
        """Draw iris ``eye`` at its gaze, clipped by the moved eye opening (in place)."""
        face = self.face
        old, radius = self._irises[eye]
        contour = EYES[eye]
        width = float(np.linalg.norm(face.points[contour[8], :2] - face.points[contour[0], :2]))
        gaze = [0.0, 0.0]
        for name, (g_eye, axis) in self._gaze.items():
            if g_eye == eye:
                gaze[axis] = float(np.clip(activations.get(name, 0.0), -1.5, 1.5))
        dx, dy = gaze[0] * GAZE_RANGE[0] * width, gaze[1] * GAZE_RANGE[1] * width
        offset = face.to_image(dx / face.iod, dy / face.iod)[0]
        centre = moved[IRIS_CENTRES[eye]] + offset
        opening = moved[list(contour)]
        h, w = image.shape[:2]
        pad = int(np.ceil(radius * 1.2)) + 2
        lo = np.floor(np.minimum(opening.min(axis=0), centre - pad)).astype(int).clip(0)
        hi = np.ceil(np.maximum(opening.max(axis=0), centre + pad)).astype(int)
        hi = np.minimum(hi, [w, h])
        rw, rh = int(hi[0] - lo[0]), int(hi[1] - lo[1])
        if rw <= 0 or rh <= 0:
            return
        mask = np.zeros((rh, rw), np.uint8)
        cv2.fillPoly(mask, [np.round((opening - lo) * 16).astype(np.int32)], 255, cv2.LINE_AA, 4)
        shift = centre - old
        matrix = np.array([[1.0, 0.0, shift[0] - lo[0]], [0.0, 1.0, shift[1] - lo[1]]], np.float32)
        iris = cv2.warpAffine(face.image, matrix, (rw, rh), flags=cv2.INTER_LINEAR)
        yy, xx = np.mgrid[0:rh, 0:rw]
        r = np.hypot(xx + lo[0] - centre[0], yy + lo[1] - centre[1])
        alpha = np.clip((radius * 1.08 - r) / 1.5, 0.0, 1.0) * (mask / 255.0)
        roi = image[lo[1] : hi[1], lo[0] : hi[0]]
        roi[:] = (roi * (1.0 - alpha[..., None]) + iris * alpha[..., None] + 0.5).astype(np.uint8)


@cache
def default_renderer() -> Renderer:
    """The bundled photo's renderer with every effect (built once per process, ~0.5 s)."""
    face = bundled_face()
    return Renderer(face, effect_shapes(face))
