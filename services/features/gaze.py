"""Gaze per eye from the iris against the eye corners, and the blink/wink rule (pure numpy).

Gaze of one eye is the iris centre in that eye's own frame: origin midway between the eye's two
corners, x along the corner line toward the performer's left (the image's right for an
unmirrored camera), y perpendicular to it, up; unit = the eye's width (corner to corner). With a
3D mesh this frame is taken in the pose-free face frame (:func:`gaze_features_3d`), otherwise in
the image (:func:`gaze_features`). The eye corners do not move when the eye looks up or down, so
the vertical gaze is read against their midpoint (the lids follow the iris, and a lid-based
centre would cancel much of the vertical gaze). Gaze is relative to the neutral (absolute minus
the neutral's absolute).

A closed eye's iris is a guess. :class:`GazeHold` applies the blink/wink rule:

* an eye counts as closed while its openness (lid gap / eye width) is below
  ``max(closed_below, closed_fraction * its neutral openness)``, and as open again once it is
  ``reopen_margin`` (relative) above that threshold (hysteresis: no flicker at the edge);
* both eyes open: each eye its own gaze;
* one eye closed (a wink, or one lost iris): the closed eye takes the open eye's gaze, because
  the eyes move together (conjugate gaze) and a robot eye that keeps looking with the other looks
  natural; the open eye keeps its own;
* both eyes closed (a blink): both hold the last gaze they showed.

Before any reliable gaze there is nothing to show, and the gaze features are left out.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Final

import numpy as np

from facesynth.services.features.pose import Similarity, apply

SIDES: Final = ("right", "left")

#: iris10 layout: right eye centre + 4 contour points, then the left eye; index of each centre.
IRIS_CENTRE: Final = {"right": 0, "left": 5}
#: Eye corners per eye, image-left one first (so the axis points to the performer's left):
#: the right eye's outer then inner corner, the left eye's inner then outer corner.
MESH_EYE_CORNERS: Final = {"right": (33, 133), "left": (362, 263)}
#: The mesh's eye contour (both lids) per eye, as the iris model's first 16 contour points.
MESH_EYE_CONTOUR: Final = {
    "right": (33, 7, 163, 144, 145, 153, 154, 155, 133, 246, 161, 160, 159, 158, 157, 173),
    "left": (263, 249, 390, 373, 374, 380, 381, 382, 362, 466, 388, 387, 386, 385, 384, 398),
}
IBUG_EYE_CORNERS: Final = {"right": (36, 39), "left": (42, 45)}

#: Openness (lid gap / eye width) below which an eye counts as closed, whatever its neutral.
#: The mesh's lids rarely meet: closed eyes measure about 0.12-0.15 on the sample video, open
#: ones 0.25-0.33 (half-lidded, looking down: about 0.2).
CLOSED_BELOW: Final = 0.15
#: ... or below this fraction of the eye's neutral openness.
CLOSED_FRACTION: Final = 0.6
#: An eye closed by the rule opens again once this much (relative) above the threshold.
REOPEN_MARGIN: Final = 0.1


def eye_gaze(
    iris_centre: np.ndarray, corner_a: np.ndarray, corner_b: np.ndarray
) -> tuple[float, float]:
    """(x, y) of an iris centre in an eye's frame (image coordinates, y down; see module doc).

    ``corner_a`` is the eye's image-left corner, ``corner_b`` its image-right one.
    """
    ax = float(corner_b[0] - corner_a[0])
    ay = float(corner_b[1] - corner_a[1])
    width2 = ax * ax + ay * ay
    if not width2 > 0 or not math.isfinite(width2):
        return math.nan, math.nan
    rx = float(iris_centre[0]) - (float(corner_a[0]) + float(corner_b[0])) / 2.0
    ry = float(iris_centre[1]) - (float(corner_a[1]) + float(corner_b[1])) / 2.0
    # x axis (ax, ay)/w; up is the x axis turned a quarter toward -y (image y points down).
    return (rx * ax + ry * ay) / width2, (rx * ay - ry * ax) / width2


def iris_depth(
    corner_a: np.ndarray,
    corner_b: np.ndarray,
    contour_mean: np.ndarray,
    up: np.ndarray,
    forward: np.ndarray,
    centre: np.ndarray,
) -> np.ndarray:
    """Depth (mesh z) of iris centres seen at ``centre`` (x, y) in the image, one per row.

    The iris moves in the eye's opening: taken as the plane through the eye's corner line and
    the head's ``up`` direction, moved along the head's ``forward`` direction to the mean depth
    of the eye's contour (the lids lie on the eyeball, in front of the corners). Corners and
    head directions are rigid, so a head turn carries this plane along, and neither a turn nor
    a lid movement changes where the iris is read. A plane seen edge-on: its origin's depth.

    Args: (n, 3) corners and contour means, (3,) unit directions, (n, 2) iris centres.
    """
    middle = (corner_a + corner_b) / 2.0
    along = ((contour_mean - middle) @ forward).tolist()
    # The rest row by row in plain floats: numpy's operations on two rows cost more than they
    # compute (the same operations in the same order: the same values, bit for bit).
    ux, uy, uz = up.tolist()
    fx, fy, fz = forward.tolist()
    depth = []
    for (mx, my, mz), (ax, ay, az), (bx, by, bz), seen, k in zip(
        middle.tolist(), corner_a.tolist(), corner_b.tolist(), centre.tolist(), along, strict=True
    ):
        ox, oy, oz = mx + k * fx, my + k * fy, mz + k * fz
        dx, dy, dz = bx - ax, by - ay, bz - az
        # normal = axis × up
        nx = dy * uz - dz * uy
        ny = dz * ux - dx * uz
        nz = dx * uy - dy * ux
        offset = nx * (seen[0] - ox) + ny * (seen[1] - oy)
        if abs(nz) < 1e-3 * math.sqrt(nx * nx + ny * ny + nz * nz):
            depth.append(oz)  # edge-on
        else:
            depth.append(oz - offset / nz if nz != 0.0 else math.nan)  # no normal: no plane
    return np.array(depth, dtype=np.float64)


#: Rows: eyes (right, left); (2, 468) matrix giving each eye contour's mean from the mesh.
_CONTOUR_MEAN = np.zeros((2, 468))
for _row, _side in enumerate(SIDES):
    _CONTOUR_MEAN[_row, list(MESH_EYE_CONTOUR[_side])] = 1.0 / len(MESH_EYE_CONTOUR[_side])
_CORNER_A = np.array([MESH_EYE_CORNERS[side][0] for side in SIDES])
_CORNER_B = np.array([MESH_EYE_CORNERS[side][1] for side in SIDES])
_CENTRES = np.array([IRIS_CENTRE[side] for side in SIDES])


def gaze_features_3d(
    iris: np.ndarray,
    mesh: np.ndarray,
    transform: Similarity,
    aligned: np.ndarray | None = None,
) -> dict[str, float]:
    """Absolute gaze of both eyes read in the face frame (eye widths), from a 3D mesh.

    ``transform`` maps the mesh onto the face frame (x toward the performer's left, y up). Each
    iris centre is lifted to 3D into its eye's opening (:func:`iris_depth`) and mapped with
    the mesh; gaze is its offset from the midpoint of the eye's corners along the eye's axis
    and along the face's up direction (made orthogonal to it), over the eye's width. So a head
    turn, which moves iris and eye together, does not read as gaze, as it partly would in the
    image (the iris sits in front of the corners). ``aligned``: the mesh already mapped.
    """
    rotation = transform[1]
    corner_a, corner_b = mesh[_CORNER_A], mesh[_CORNER_B]
    centres = iris[_CENTRES]
    # the face frame's y and z in mesh coordinates are the rotation's rows
    lifted = np.empty((2, 3))
    lifted[:, :2] = centres
    lifted[:, 2] = iris_depth(
        corner_a, corner_b, _CONTOUR_MEAN @ mesh, rotation[1], rotation[2], centres
    )
    centre = apply(transform, lifted).tolist()
    if aligned is None:
        ends = apply(transform, np.concatenate([corner_a, corner_b])).tolist()
        a, b = ends[:2], ends[2:]
    else:
        a, b = aligned[_CORNER_A].tolist(), aligned[_CORNER_B].tolist()
    out: dict[str, float] = {}
    for side, (ax, ay, az), (bx, by, bz), (cx, cy, cz) in zip(SIDES, a, b, centre, strict=True):
        gx, gy = _eye_frame_gaze(
            bx - ax,
            by - ay,
            bz - az,
            cx - (ax + bx) / 2.0,
            cy - (ay + by) / 2.0,
            cz - (az + bz) / 2.0,
        )
        if math.isfinite(gx) and math.isfinite(gy):
            out[f"gaze_{side}_x"] = gx
            out[f"gaze_{side}_y"] = gy
    return out


def _eye_frame_gaze(
    ax: float, ay: float, az: float, ox: float, oy: float, oz: float
) -> tuple[float, float]:
    """Gaze of one eye in the face frame: the offset ``o`` of its iris centre from the eye's
    corners' midpoint along the eye's axis ``a`` (corner to corner) and along the face's up
    direction made orthogonal to it, over the eye's width (plain floats, one eye)."""
    width = math.sqrt(ax * ax + ay * ay + az * az)
    if width == 0.0:  # no eye: no gaze (as numpy's NaN of 0 / 0 was)
        return math.nan, math.nan
    ex, ey, ez = ax / width, ay / width, az / width
    # up (0, 1, 0) less its part along the axis, then made unit
    ux, uy, uz = 0.0 - ey * ex, 1.0 - ey * ey, 0.0 - ey * ez
    norm = math.sqrt(ux * ux + uy * uy + uz * uz)
    if norm == 0.0:  # the eye's axis is the face's up
        return math.nan, math.nan
    ux, uy, uz = ux / norm, uy / norm, uz / norm
    return (ox * ex + oy * ey + oz * ez) / width, (ox * ux + oy * uy + oz * uz) / width


def gaze_features(
    iris: np.ndarray, mesh: np.ndarray | None, ibug68: np.ndarray
) -> dict[str, float]:
    """Absolute gaze of both eyes (``gaze_<side>_x``, ``gaze_<side>_y``) in the image's eye
    frames, eye widths (without a 3D mesh; see :func:`gaze_features_3d`).

    Eye corners come from the mesh when there is one, else from the 68 points.
    """
    out: dict[str, float] = {}
    for side in SIDES:
        if mesh is not None:
            a, b = MESH_EYE_CORNERS[side]
            corner_a, corner_b = mesh[a], mesh[b]
        else:
            a, b = IBUG_EYE_CORNERS[side]
            corner_a, corner_b = ibug68[a], ibug68[b]
        x, y = eye_gaze(iris[IRIS_CENTRE[side]], corner_a, corner_b)
        if math.isfinite(x) and math.isfinite(y):
            out[f"gaze_{side}_x"] = x
            out[f"gaze_{side}_y"] = y
    return out


class GazeHold:
    """The blink/wink rule on relative gaze (see the module doc)."""

    def __init__(
        self,
        closed_below: float = CLOSED_BELOW,
        closed_fraction: float = CLOSED_FRACTION,
        reopen_margin: float = REOPEN_MARGIN,
    ) -> None:
        self.closed_below = closed_below
        self.closed_fraction = closed_fraction
        self.reopen_margin = reopen_margin
        self.closed = {side: False for side in SIDES}
        self.shown: dict[str, tuple[float, float]] = {}

    def threshold(self, neutral_openness: float | None) -> float:
        """Openness below which an eye with this neutral openness counts as closed."""
        if neutral_openness is None or not math.isfinite(neutral_openness):
            return self.closed_below
        return max(self.closed_below, self.closed_fraction * neutral_openness)

    def eye_open(self, side: str, openness: float | None, neutral_openness: float | None) -> bool:
        """Update and return whether one eye is open (unknown openness: open)."""
        if openness is None or not math.isfinite(openness):
            self.closed[side] = False
            return True
        threshold = self.threshold(neutral_openness)
        if self.closed[side]:
            self.closed[side] = openness < threshold * (1.0 + self.reopen_margin)
        else:
            self.closed[side] = openness < threshold
        return not self.closed[side]

    def observe(self, openness: Mapping[str, float], neutral_openness: Mapping[str, float]) -> None:
        """Update which eyes are closed from absolute and neutral ``eye_open_<side>`` values."""
        for side in SIDES:
            key = f"eye_open_{side}"
            self.eye_open(side, openness.get(key), neutral_openness.get(key))

    def hold(self, gaze: Mapping[str, float]) -> dict[str, float]:
        """Held relative gaze (``gaze_<side>_x|y``) from relative gaze, by the last observation."""
        reliable: dict[str, tuple[float, float]] = {}
        for side in SIDES:
            x, y = gaze.get(f"gaze_{side}_x"), gaze.get(f"gaze_{side}_y")
            if not self.closed[side] and x is not None and y is not None:
                reliable[side] = (x, y)
        for side in SIDES:
            other = "left" if side == "right" else "right"
            if side in reliable:
                self.shown[side] = reliable[side]
            elif other in reliable:
                self.shown[side] = reliable[other]
            # else: both closed or no iris: hold what was shown
        out: dict[str, float] = {}
        for side in SIDES:
            if side in self.shown:
                out[f"gaze_{side}_x"], out[f"gaze_{side}_y"] = self.shown[side]
        return out

    def update(
        self,
        gaze: Mapping[str, float],
        openness: Mapping[str, float],
        neutral_openness: Mapping[str, float],
    ) -> dict[str, float]:
        """:meth:`observe` then :meth:`hold`."""
        self.observe(openness, neutral_openness)
        return self.hold(gaze)
