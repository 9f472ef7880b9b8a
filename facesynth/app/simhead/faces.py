"""Synthetic faces with known motion: a still face warped into expressions, for fidelity tests.

A still frame of the bundled performer video and its 478 landmarks (Face Landmarker v2, the
``full`` tracker model) are the starting point. An :class:`Expression` moves chosen landmarks
by known amounts in the face's own frame (x toward the performer's left, y up, unit = the
inter-ocular distance between the outer eye corners, IOD); the image is warped to follow them:

* every mesh vertex gets a displacement (a smooth falloff from the moving features, 0 far
  away), and each pixel of the output takes the source pixel at minus the Nadaraya-Watson
  (Gaussian-weighted) mean of the displacements of the vertices near it, taken at their new
  places (:func:`warp`); far from the face nothing moves;
* a jaw drop paints the opened mouth (between the inner lips) dark;
* gaze redraws the irises: the eye openings are filled with the sclera (inpainted) and each
  iris disc, copied from the original, is pasted at its new centre and clipped by the (possibly
  moved) lids, so the lids cover it where they should.

The base frame has no perfectly neutral face (nobody in the sample is neutral: see
``tests/integration/test_face_sections.py``); its own slight smile and gaze are the baseline,
and every expression is a change from it. The irises are re-centred in the baseline itself, so
the four gaze directions start from the middle of each eye.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final

import cv2
import numpy as np

__all__ = [
    "BASE_FRAME",
    "EXPRESSIONS",
    "Expression",
    "Face",
    "base_face",
    "falloff",
    "iris_radius",
    "remove_irises",
    "render",
    "warp",
]

#: The frame of the bundled video used as the still face (9.95 s: head up, slight smile).
BASE_FRAME: Final = 240

# MediaPipe face-mesh topology (google-ai-edge/mediapipe, face_mesh_connections.py): the
# performer's right eye / brow are on the image's left.
RIGHT_EYE: Final = (33, 246, 161, 160, 159, 158, 157, 173, 133, 155, 154, 153, 145, 144, 163, 7)
LEFT_EYE: Final = (263, 466, 388, 387, 386, 385, 384, 398, 362, 382, 381, 380, 374, 373, 390, 249)
UPPER_LIDS: Final = ((246, 161, 160, 159, 158, 157, 173), (466, 388, 387, 386, 385, 384, 398))
LOWER_LIDS: Final = ((7, 163, 144, 145, 153, 154, 155), (249, 390, 373, 374, 380, 381, 382))
RIGHT_BROW: Final = (70, 63, 105, 66, 107, 46, 53, 52, 65, 55)
LEFT_BROW: Final = (300, 293, 334, 296, 336, 276, 283, 282, 295, 285)
INNER_BROW: Final = ((107, 55, 66, 65), (336, 285, 296, 295))
UPPER_INNER_LIP: Final = (78, 191, 80, 81, 82, 13, 312, 311, 310, 415, 308)
LOWER_INNER_LIP: Final = (78, 95, 88, 178, 87, 14, 317, 402, 318, 324, 308)
LIP_CORNERS: Final = (61, 291)
IRIS_CENTRES: Final = (468, 473)
IRIS_CONTOURS: Final = ((469, 470, 471, 472), (474, 475, 476, 477))
EYES: Final = (RIGHT_EYE, LEFT_EYE)
MOUTH_DARK: Final = (32, 18, 24)  # BGR: the inside of an opened mouth


@dataclass(frozen=True)
class Face:
    """A still face: the image (BGR) and its 478 landmarks (x, y in pixels; z)."""

    image: np.ndarray
    points: np.ndarray

    @property
    def iod(self) -> float:
        """Inter-ocular distance (outer eye corners 33-263) in pixels."""
        return float(np.linalg.norm(self.points[263, :2] - self.points[33, :2]))

    def axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(origin, x, up) of the face frame in image pixels: x toward the performer's left,
        up toward the top of the head, both unit vectors; origin between the outer corners."""
        a, b = self.points[33, :2], self.points[263, :2]
        x = (b - a) / np.linalg.norm(b - a)
        return (a + b) / 2.0, x, np.array([x[1], -x[0]])

    def to_image(self, dx: np.ndarray | float, dy: np.ndarray | float) -> np.ndarray:
        """Displacements given in the face frame (IOD) as image pixels, shape (n, 2)."""
        _, x, up = self.axes()
        dx, dy = np.atleast_1d(dx), np.atleast_1d(dy)
        return self.iod * (dx[:, None] * x + dy[:, None] * up)

    def local(self) -> np.ndarray:
        """The 478 points in the face frame (IOD; x toward the performer's left, y up)."""
        origin, x, up = self.axes()
        rel = self.points[:, :2] - origin
        return np.column_stack([rel @ x, rel @ up]) / self.iod


@dataclass(frozen=True)
class Expression:
    """A known change of a face: mesh displacements, iris shift, an opened mouth.

    Attributes:
        name: what it is (``smile``, ``look_up`` ...).
        move: (478, 2) displacements of the landmarks in the face frame (IOD).
        gaze: (x, y) iris shift in eye widths (x toward the performer's left, y up).
        mouth_open: paint the space between the inner lips dark.
    """

    name: str
    move: np.ndarray
    gaze: tuple[float, float] = (0.0, 0.0)
    mouth_open: bool = False


def falloff(local: np.ndarray, centres: np.ndarray, sigma: float) -> np.ndarray:
    """Per point, the Gaussian weight of its distance to the nearest of ``centres``."""
    d2 = ((local[:, None, :] - centres[None, :, :]) ** 2).sum(axis=2).min(axis=1)
    weight: np.ndarray = np.exp(-d2 / (2.0 * sigma * sigma))
    return weight


def _eyes_still(move: np.ndarray) -> np.ndarray:
    move[list(RIGHT_EYE) + list(LEFT_EYE) + list(range(468, 478))] = 0.0
    return move


def smile(face: Face, out: float = 0.07, up: float = 0.06) -> np.ndarray:
    """Lip corners pulled out and up (AU12) by ``out`` / ``up`` IOD, with their surroundings."""
    local = face.local()
    move = np.zeros((478, 2))
    for corner, sign in zip(LIP_CORNERS, (-1.0, 1.0), strict=True):
        weight = falloff(local, local[[corner]], 0.12)
        move += weight[:, None] * np.array([sign * out, up])
    return _eyes_still(move)


def brow_raise(face: Face, up: float = 0.08) -> np.ndarray:
    """Both brows raised by ``up`` IOD, the skin around them following (fading within about
    0.1 IOD: the upper forehead stays)."""
    local = face.local()
    brows = local[list(RIGHT_BROW) + list(LEFT_BROW)]
    weight = falloff(local, brows, 0.08)
    move = np.zeros((478, 2))
    move[:, 1] = up * weight
    return _eyes_still(move)


def frown(face: Face, down: float = 0.05, inward: float = 0.035) -> np.ndarray:
    """Both brows lowered by ``down`` IOD, their inner ends drawn toward the midline."""
    local = face.local()
    move = np.zeros((478, 2))
    brows = local[list(RIGHT_BROW) + list(LEFT_BROW)]
    move[:, 1] = -down * falloff(local, brows, 0.08)
    for inner, sign in zip(INNER_BROW, (1.0, -1.0), strict=True):
        move[:, 0] += sign * inward * falloff(local, local[list(inner)], 0.08)
    return _eyes_still(move)


def jaw_open(face: Face, drop: float = 0.22) -> np.ndarray:
    """The jaw dropped by ``drop`` IOD at the chin: everything below the lip corners' line
    moves down, in proportion to how far below it is (a hinge), the upper lip stays."""
    local = face.local()
    corners_y = float(local[list(LIP_CORNERS), 1].mean())
    lower_lip_y = float(local[list(LOWER_INNER_LIP), 1].min())
    depth = np.clip((corners_y - local[:, 1]) / max(corners_y - lower_lip_y, 1e-6), 0.0, 1.0)
    move = np.zeros((478, 2))
    move[:, 1] = -drop * depth
    move[list(UPPER_INNER_LIP)[1:-1], 1] = 0.0
    return _eyes_still(move)


def look(face: Face, dx: float, dy: float, lids: float = 0.0) -> tuple[np.ndarray, tuple]:
    """Gaze moved by (dx, dy) eye widths; with ``lids`` the upper lids follow the vertical
    part by that fraction of the iris's move (the lower lids by half of it)."""
    move = np.zeros((478, 2))
    if lids and dy:
        width = float(np.linalg.norm(face.points[133, :2] - face.points[33, :2])) / face.iod
        for upper, lower in zip(UPPER_LIDS, LOWER_LIDS, strict=True):
            move[list(upper), 1] = lids * dy * width
            move[list(lower), 1] = 0.5 * lids * dy * width
    return move, (dx, dy)


def lids(face: Face, upper: float, lower: float) -> np.ndarray:
    """The lids alone moved (eye widths; + = up): eyes widened or squinted, the irises still."""
    move = np.zeros((478, 2))
    width = float(np.linalg.norm(face.points[133, :2] - face.points[33, :2])) / face.iod
    for upper_lid, lower_lid in zip(UPPER_LIDS, LOWER_LIDS, strict=True):
        move[list(upper_lid), 1] = upper * width
        move[list(lower_lid), 1] = lower * width
    return move


def expressions(face: Face) -> list[Expression]:
    """The catalogue: the paper's face sections with known motion (see the module doc)."""
    out = [
        Expression("smile", smile(face)),
        Expression("brow_raise", brow_raise(face)),
        Expression("frown", frown(face)),
        Expression("jaw_open", jaw_open(face), mouth_open=True),
    ]
    for name, dx, dy, follow in (
        ("look_left", 0.16, 0.0, 0.0),
        ("look_right", -0.16, 0.0, 0.0),
        ("look_up", 0.0, 0.09, 0.0),
        ("look_down", 0.0, -0.09, 0.0),
        ("look_up_lids", 0.0, 0.09, 0.6),
        ("look_down_lids", 0.0, -0.09, 0.6),
    ):
        move, gaze = look(face, dx, dy, follow)
        out.append(Expression(name, move, gaze))
    out.append(Expression("eyes_wide", lids(face, 0.06, -0.02)))
    out.append(Expression("squint", lids(face, -0.07, 0.04)))
    return out


#: The expressions' names, in the catalogue's order.
EXPRESSIONS: Final = (
    "smile",
    "brow_raise",
    "frown",
    "jaw_open",
    "look_left",
    "look_right",
    "look_up",
    "look_down",
    "look_up_lids",
    "look_down_lids",
    "eyes_wide",
    "squint",
)


def warp(image: np.ndarray, points: np.ndarray, moves: np.ndarray, sigma: float) -> np.ndarray:
    """``image`` warped so that pixels at ``points`` (n, 2) move by ``moves`` (n, 2) pixels.

    The backward map at each pixel p is p minus the Gaussian-weighted mean of the moves of the
    points near p (weights taken at the points' new places, ``sigma`` pixels wide, with a
    zero-move background weight so that far from every point nothing moves).
    """
    h, w = image.shape[:2]
    moving = np.abs(moves).sum(axis=1) > 1e-9
    if not moving.any():
        return image.copy()
    targets = points + moves
    lo = np.floor(targets[moving].min(axis=0) - 4 * sigma).astype(int).clip(0, [w - 1, h - 1])
    hi = np.ceil(targets[moving].max(axis=0) + 4 * sigma).astype(int).clip(0, [w - 1, h - 1])
    xs, ys = np.meshgrid(np.arange(lo[0], hi[0] + 1), np.arange(lo[1], hi[1] + 1))
    grid = np.stack([xs.ravel(), ys.ravel()], axis=1).astype(np.float64)
    near = np.abs(targets - (lo + hi) / 2.0).max(axis=1) <= ((hi - lo) / 2.0).max() + 4 * sigma
    anchors, shifts = targets[near], moves[near]
    numerator = np.zeros_like(grid)
    denominator = np.full(len(grid), np.exp(-4.5))  # the background: 3 sigma from any point
    for start in range(0, len(anchors), 64):
        block = slice(start, start + 64)
        d2 = ((grid[:, None, :] - anchors[None, block, :]) ** 2).sum(axis=2)
        weight = np.exp(-d2 / (2.0 * sigma * sigma))
        numerator += weight @ shifts[block]
        denominator += weight.sum(axis=1)
    field = numerator / denominator[:, None]
    map_x = np.tile(np.arange(w, dtype=np.float32), (h, 1))
    map_y = np.tile(np.arange(h, dtype=np.float32)[:, None], (1, w))
    map_x[ys, xs] -= field[:, 0].reshape(xs.shape).astype(np.float32)
    map_y[ys, xs] -= field[:, 1].reshape(xs.shape).astype(np.float32)
    return cv2.remap(image, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)


def _eye_masks(shape: tuple[int, ...], points: np.ndarray) -> list[np.ndarray]:
    masks = []
    for eye in EYES:
        mask = np.zeros(shape[:2], np.uint8)
        cv2.fillPoly(mask, [np.round(points[list(eye), :2]).astype(np.int32)], 255)
        masks.append(mask)
    return masks


def iris_radius(points: np.ndarray, eye: int) -> float:
    """The mean radius (pixels) of iris ``eye`` (0 right, 1 left) from its contour points."""
    contour = points[list(IRIS_CONTOURS[eye]), :2]
    return float(np.linalg.norm(contour - points[IRIS_CENTRES[eye], :2], axis=1).mean())


def remove_irises(image: np.ndarray, points: np.ndarray) -> np.ndarray:
    """``image`` with both irises (at ``points``' iris landmarks) painted over with the
    surrounding sclera and lids (inpainted), so they can be drawn elsewhere."""
    hole = np.zeros(image.shape[:2], np.uint8)
    for eye in range(2):
        centre = tuple(np.round(points[IRIS_CENTRES[eye], :2]).astype(int))
        cv2.circle(hole, centre, int(np.ceil(iris_radius(points, eye) * 1.15)), 255, -1)
    widened: np.ndarray = cv2.dilate(hole, np.ones((3, 3), np.uint8))
    result: np.ndarray = cv2.inpaint(image, widened, 5, cv2.INPAINT_TELEA)
    return result


def _draw_irises(
    image: np.ndarray,
    source: np.ndarray,
    points: np.ndarray,
    lids: np.ndarray,
    centres: list[np.ndarray],
) -> np.ndarray:
    """Fill the eye openings (``lids``' contours) with sclera, then paste each iris of
    ``source`` (at ``points``' iris centres) at ``centres``, clipped by the openings."""
    out = image.copy()
    old_masks = _eye_masks(image.shape, points)
    for eye, mask in enumerate(_eye_masks(image.shape, lids)):
        radius = iris_radius(points, eye)
        old = points[IRIS_CENTRES[eye], :2]
        disc = np.zeros(image.shape[:2], np.uint8)
        cv2.circle(disc, tuple(np.round(old).astype(int)), int(np.ceil(radius * 1.15)), 255, -1)
        widened = mask & ~old_masks[eye]  # an opening the lids widened: no sclera there yet
        hole = cv2.dilate(disc | widened, np.ones((3, 3), np.uint8))
        sclera = cv2.inpaint(source, hole, 5, cv2.INPAINT_TELEA)
        out[mask > 0] = sclera[mask > 0]
        dx, dy = centres[eye] - old
        shift = np.array([[1.0, 0.0, dx], [0.0, 1.0, dy]], np.float32)
        size = (image.shape[1], image.shape[0])
        moved = cv2.warpAffine(source, shift, size, flags=cv2.INTER_LINEAR)
        yy, xx = np.mgrid[: image.shape[0], : image.shape[1]]
        r = np.hypot(xx - centres[eye][0], yy - centres[eye][1])
        alpha = np.clip((radius * 1.08 - r) / 1.5, 0.0, 1.0) * (mask > 0)
        out = (out * (1.0 - alpha[..., None]) + moved * alpha[..., None]).astype(np.uint8)
    return out


def base_face(frame: np.ndarray, points: np.ndarray) -> Face:
    """The baseline face: ``frame`` (BGR) with its irises redrawn in the middle of each eye
    opening (between the eye corners, halfway up the opening), and its landmarks to match."""
    face = Face(frame, points.astype(np.float64))
    centres = []
    new = face.points.copy()
    for eye, contour in enumerate(EYES):
        opening = face.points[list(contour), :2]
        corners = face.points[[contour[0], contour[8]], :2]
        centre = np.array([corners[:, 0].mean(), (opening[:, 1].min() + opening[:, 1].max()) / 2])
        shift = centre - face.points[IRIS_CENTRES[eye], :2]
        rows = [IRIS_CENTRES[eye], *IRIS_CONTOURS[eye]]
        new[rows, :2] += shift
        centres.append(centre)
    image = _draw_irises(frame, frame, face.points, face.points, centres)
    return Face(image, new)


def render(face: Face, expression: Expression) -> np.ndarray:
    """The face's image showing ``expression``."""
    moves = face.to_image(expression.move[:, 0], expression.move[:, 1])
    mesh = face.points[:468, :2]
    image = warp(face.image, mesh, moves[:468], sigma=0.035 * face.iod)
    moved = face.points[:, :2] + moves
    if expression.mouth_open:
        lips = np.concatenate([moved[list(UPPER_INNER_LIP)], moved[list(LOWER_INNER_LIP)][::-1]])
        cv2.fillPoly(image, [np.round(lips).astype(np.int32)], MOUTH_DARK, cv2.LINE_AA)
    dx, dy = expression.gaze
    if dx or dy or np.abs(moves[list(RIGHT_EYE) + list(LEFT_EYE)]).max() > 0:
        centres = []
        for eye, contour in enumerate(EYES):
            a, b = face.points[contour[0], :2], face.points[contour[8], :2]
            width = float(np.linalg.norm(b - a))
            centre = face.points[IRIS_CENTRES[eye], :2]
            centres.append(centre + face.to_image(dx * width / face.iod, dy * width / face.iod)[0])
        lids = face.points.copy()
        lids[:, :2] = moved
        image = _draw_irises(image, face.image, face.points, lids, centres)
    return image
