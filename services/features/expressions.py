"""Named expression features (``facesynth.runtime.feature_names``) from landmarks (pure numpy).

:func:`raw_features` gives the ABSOLUTE raw value of every named feature the inputs support;
relative to the performer's neutral is absolute minus the neutral's absolute (:func:`relative`),
then :func:`scale` maps it onto the calibrated range.

Where the points come from:

* with the 3D mesh, expressions are read from the mesh aligned onto the neutral mesh's face
  frame (``services.features.pose``: similarity fit on stable vertices), so a head turn does not
  read as a smile or a brow raise; the unit is the NEUTRAL face's inter-ocular distance (IOD), so
  a turned head (shorter eye line in the image) does not rescale features. Without a neutral
  mesh, the mesh's own face frame is used;
* with the 68 points only (e.g. OpenFace replay), expressions are read in the eye-corner frame
  of ``services.features.core.normalise`` (y flipped to point up), unit = the current IOD; head
  yaw, head pitch and cheek raise are left out (2D points cannot tell them apart from identity
  and expression), head roll is the image eye line's angle.

Per feature, ``<side>`` is the performer's ``right`` or ``left``; "out" is away from the face's
midline; y is up:

* ``head_yaw|pitch|roll``: rotation from the neutral mesh (degrees; see ``pose``);
* ``gaze_<side>_x|y``: iris centre in the eye's frame (in the face frame with a mesh, else in
  the image), eye widths (see ``gaze``);
* ``eye_open_<side>``: (upper lid − lower lid) height / eye width (corner to corner);
* ``brow_raise_inner|outer_<side>``: height of the inner / outer half of the brow;
* ``brow_lower_<side>``: depth of the whole brow (−height) minus the inner end's horizontal
  distance from the nasion (down and together);
* ``lid_tighten_<side>``: height of the lower lid above the eye corners' midpoint;
* ``cheek_raise_<side>``: height of the infraorbital cheek (mesh only);
* ``lip_corner_pull_<side>``: the lip corner against the mouth's centre (midway between the
  middles of the upper and lower lip's outer edges), projected on (out + up)/√2 (a smile);
* ``lip_corner_depress_<side>``: the same on (out − up)/√2, orthogonal to the smile direction
  (corners down). A jaw drop that takes the corners half as far as the lower lip moves them
  with the mouth's centre and reads 0 on both;
* ``jaw_open``: depth of the chin (−height);
* ``lips_part``: inner upper lip height minus inner lower lip height;
* ``lip_pucker``: minus the mouth width (corner to corner, horizontal).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
from typing import Final, NamedTuple

import numpy as np

from facesynth.runtime.feature_names import BY_NAME, NAMES, SCALED_LIMIT
from facesynth.runtime.landmarks import LEFT_EYE_OUTER, RIGHT_EYE_OUTER
from facesynth.services.features.frame import normalise
from facesynth.services.features.gaze import gaze_features, gaze_features_3d
from facesynth.services.features.pose import (
    N_MESH,
    MeshReference,
    Similarity,
    apply,
    camera_pose,
    euler_degrees,
    own_frame,
    roll_2d,
)

SIDES: Final = ("right", "left")
#: Sign that turns x (toward the performer's left) into "away from the midline" per side.
OUTWARD: Final = {"right": -1.0, "left": 1.0}
HEAD: Final = ("head_yaw", "head_pitch", "head_roll")
#: Features that need the mesh (2D points cannot separate them from identity and pose).
MESH_ONLY: Final = frozenset({"head_yaw", "head_pitch", "cheek_raise_right", "cheek_raise_left"})
_INV_SQRT2: Final = 1.0 / math.sqrt(2.0)


@dataclass(frozen=True)
class Landmarks:
    """One landmark group: iBUG 68 indices (empty: mesh only) and mesh vertices."""

    ibug: tuple[int, ...]
    mesh: tuple[int, ...]


def _sided(right: Landmarks, left: Landmarks) -> dict[str, Landmarks]:
    return {"right": right, "left": left}


#: Landmark groups, per side where sided. Mesh vertices are MediaPipe's, left = mirror of right.
BROW_INNER: Final = _sided(
    Landmarks((20, 21), (66, 107, 65, 55)), Landmarks((22, 23), (296, 336, 295, 285))
)
BROW_OUTER: Final = _sided(
    Landmarks((17, 18), (70, 63, 46, 53)), Landmarks((25, 26), (300, 293, 276, 283))
)
BROW: Final = _sided(
    Landmarks((17, 18, 19, 20, 21), (70, 63, 105, 66, 107, 46, 53, 52, 65, 55)),
    Landmarks((22, 23, 24, 25, 26), (300, 293, 334, 296, 336, 276, 283, 282, 295, 285)),
)
EYE_OUTER: Final = _sided(Landmarks((36,), (33,)), Landmarks((45,), (263,)))
EYE_INNER: Final = _sided(Landmarks((39,), (133,)), Landmarks((42,), (362,)))
LID_UPPER: Final = _sided(
    Landmarks((37, 38), (160, 159, 158)), Landmarks((43, 44), (385, 386, 387))
)
LID_LOWER: Final = _sided(
    Landmarks((41, 40), (144, 145, 153)), Landmarks((47, 46), (380, 374, 373))
)
CHEEK: Final = _sided(
    Landmarks((), (50, 101, 117, 118, 123)), Landmarks((), (280, 330, 346, 347, 352))
)
LIP_CORNER: Final = _sided(Landmarks((48,), (61,)), Landmarks((54,), (291,)))
#: Midline of the mouth's outline: the middle of the upper and of the lower lip's outer edge.
MOUTH_MIDLINE: Final = Landmarks((51, 57), (0, 17))
LIP_UPPER_INNER: Final = Landmarks((61, 62, 63), (82, 13, 312))
LIP_LOWER_INNER: Final = Landmarks((67, 66, 65), (87, 14, 317))
CHIN: Final = Landmarks((8,), (152,))
#: Top of the nose bridge, between the eyes: the midline for the brows.
NASION: Final = Landmarks((27,), (168,))


def _groups() -> dict[str, Landmarks]:
    groups = {
        "mouth_midline": MOUTH_MIDLINE,
        "lip_upper_inner": LIP_UPPER_INNER,
        "lip_lower_inner": LIP_LOWER_INNER,
        "chin": CHIN,
        "nasion": NASION,
    }
    for stem, table in (
        ("brow_inner", BROW_INNER),
        ("brow_outer", BROW_OUTER),
        ("brow", BROW),
        ("eye_outer", EYE_OUTER),
        ("eye_inner", EYE_INNER),
        ("lid_upper", LID_UPPER),
        ("lid_lower", LID_LOWER),
        ("cheek", CHEEK),
        ("lip_corner", LIP_CORNER),
    ):
        for side in SIDES:
            groups[f"{stem}_{side}"] = table[side]
    return groups


GROUPS: Final[dict[str, Landmarks]] = _groups()
_ORDER: Final = tuple(GROUPS)
_ROW: Final = {name: i for i, name in enumerate(_ORDER)}


@lru_cache(maxsize=2)
def _mean_matrix(mesh: bool) -> np.ndarray:
    """(groups, points) matrix whose product with the points gives each group's mean."""
    matrix = np.zeros((len(_ORDER), N_MESH if mesh else 68))
    for i, name in enumerate(_ORDER):
        members = GROUPS[name].mesh if mesh else GROUPS[name].ibug
        if members:
            matrix[i, list(members)] = 1.0 / len(members)
    matrix.setflags(write=False)
    return matrix


def face_frame_2d(ibug68: np.ndarray) -> np.ndarray:
    """The 68 points in the eye-corner frame, y up (``core.normalise`` with y flipped)."""
    result: np.ndarray = normalise(ibug68) * np.array([1.0, -1.0])
    return result


class _SideRows(NamedTuple):
    """One side's rows of ``_expressions``' group means (so its loop looks no name up)."""

    side: str
    sign: float
    eye_outer: int
    eye_inner: int
    lid_upper: int
    lid_lower: int
    brow_inner: int
    brow_outer: int
    brow: int
    cheek: int
    lip_corner: int


_SIDE_ROWS: Final = tuple(
    _SideRows(
        side,
        OUTWARD[side],
        *(_ROW[f"{stem}_{side}"] for stem in _SideRows._fields[2:]),
    )
    for side in SIDES
)


def _expressions(g: np.ndarray, *, mesh: bool) -> dict[str, float]:
    """Expression features from group means ``g`` (groups × (x, y[, z])) in a y-up face frame.

    Plain floats (one ``tolist``), the same operations in the same order as on numpy scalars:
    the values are those, bit for bit, at a fraction of the cost.
    """
    rows = g.tolist()
    out: dict[str, float] = {}
    mouth = rows[_ROW["mouth_midline"]]
    nasion_x = rows[_ROW["nasion"]][0]
    for r in _SIDE_ROWS:
        side, sign = r.side, r.sign
        outer, inner = rows[r.eye_outer], rows[r.eye_inner]
        upper, lower = rows[r.lid_upper], rows[r.lid_lower]
        width = _norm([o - i for o, i in zip(outer, inner, strict=True)])
        out[f"eye_open_{side}"] = (upper[1] - lower[1]) / width if width > 0 else math.nan
        brow_inner = rows[r.brow_inner]
        out[f"brow_raise_inner_{side}"] = brow_inner[1]
        out[f"brow_raise_outer_{side}"] = rows[r.brow_outer][1]
        inner_out = sign * (brow_inner[0] - nasion_x)
        out[f"brow_lower_{side}"] = -rows[r.brow][1] - inner_out
        out[f"lid_tighten_{side}"] = lower[1] - (outer[1] + inner[1]) / 2.0
        if mesh:
            out[f"cheek_raise_{side}"] = rows[r.cheek][1]
        corner = rows[r.lip_corner]
        outward = sign * (corner[0] - mouth[0])
        up = corner[1] - mouth[1]
        out[f"lip_corner_pull_{side}"] = (outward + up) * _INV_SQRT2
        out[f"lip_corner_depress_{side}"] = (outward - up) * _INV_SQRT2
    out["jaw_open"] = -rows[_ROW["chin"]][1]
    out["lips_part"] = rows[_ROW["lip_upper_inner"]][1] - rows[_ROW["lip_lower_inner"]][1]
    left, right = rows[_ROW["lip_corner_left"]], rows[_ROW["lip_corner_right"]]
    out["lip_pucker"] = -(left[0] - right[0])
    return {name: value for name, value in out.items() if math.isfinite(value)}


def _norm(vector: list[float]) -> float:
    """``np.linalg.norm`` of a short vector (the same value: the square root of its dot)."""
    return math.sqrt(float(np.dot(vector, vector)))


def _reference(neutral_mesh: MeshReference | np.ndarray | None) -> MeshReference | None:
    if neutral_mesh is None or isinstance(neutral_mesh, MeshReference):
        return neutral_mesh
    return MeshReference(np.asarray(neutral_mesh, dtype=np.float64).reshape(N_MESH, 3))


def raw_features(
    ibug68: np.ndarray,
    mesh: np.ndarray | None = None,
    iris: np.ndarray | None = None,
    neutral_mesh: MeshReference | np.ndarray | None = None,
    transform: Similarity | None = None,
) -> dict[str, float]:
    """Absolute raw values of the named features these inputs support (see the module doc).

    Args:
        ibug68: (68, 2) image points.
        mesh: (468, 3) mesh in image pixels (z away from the camera), or None.
        iris: (10, 2) iris points (right eye centre + 4, then left), or None.
        neutral_mesh: the neutral mesh ((468, 3) array, or a prepared :class:`MeshReference`):
            the face frame expressions are read in and the origin of head pose. Without it the
            current mesh's own face frame is used and head pose is against the camera's axes.
        transform: the mesh's fit onto the neutral's face frame when the caller has it
            (``MeshReference.fits(mesh)[1]``; used only with ``neutral_mesh``).

    Raises:
        services.features.frame.FeatureError: degenerate eye corners (no 2D face frame) or a
            degenerate mesh (:class:`~facesynth.services.features.pose.PoseError`, a subclass).
    """
    reference = _reference(neutral_mesh)
    out: dict[str, float] = {}
    if mesh is not None:
        if reference is not None:
            if transform is None:
                transform = reference.fit(mesh)
            yaw, pitch, roll = euler_degrees(reference.head_rotation(transform))
        else:
            transform = own_frame(mesh)
            yaw, pitch, roll = camera_pose(mesh)
        out.update(head_yaw=yaw, head_pitch=pitch, head_roll=roll)
        aligned = apply(transform, mesh)
        out.update(_expressions(_mean_matrix(True) @ aligned, mesh=True))
        if iris is not None:
            out.update(gaze_features_3d(iris, mesh, transform, aligned))
    else:
        out["head_roll"] = roll_2d(ibug68[RIGHT_EYE_OUTER], ibug68[LEFT_EYE_OUTER])
        out.update(_expressions(_mean_matrix(False) @ face_frame_2d(ibug68), mesh=False))
        if iris is not None:
            out.update(gaze_features(iris, None, ibug68))
    return out


def relative(raw: Mapping[str, float], neutral: Mapping[str, float]) -> dict[str, float]:
    """Raw values relative to the neutral's; features without a neutral value are left out.

    Head pose from the mesh is already relative to the neutral mesh: a missing neutral value
    counts as 0 for ``head_*``.
    """
    out: dict[str, float] = {}
    for name, value in raw.items():
        if name in neutral:
            out[name] = value - neutral[name]
        elif name in HEAD:
            out[name] = value
    return out


def default_ranges() -> dict[str, tuple[float, float]]:
    """The contract's default raw range (min < 0 < max) of every named feature."""
    return {name: (BY_NAME[name].default_min, BY_NAME[name].default_max) for name in NAMES}


def ranges_from(
    named_min: Mapping[str, float], named_max: Mapping[str, float]
) -> dict[str, tuple[float, float]]:
    """Calibrated ranges where given (each side separately), the defaults elsewhere."""
    out = default_ranges()
    for name, (lo, hi) in out.items():
        out[name] = (named_min.get(name, lo), named_max.get(name, hi))
    return out


def scale_value(value: float, lo: float, hi: float) -> float:
    """``value / hi`` if non-negative else ``value / -lo``, clamped to ±SCALED_LIMIT."""
    scaled = value / hi if value >= 0 else value / -lo
    return max(-SCALED_LIMIT, min(SCALED_LIMIT, scaled))


def scale(rel: Mapping[str, float], ranges: Mapping[str, tuple[float, float]]) -> dict[str, float]:
    """Relative raw values scaled to their ranges (0 neutral, ±1 at the range's ends).

    :func:`scale_value` written out in the loop (a call per feature cost more than the sum).
    """
    out: dict[str, float] = {}
    high, low = SCALED_LIMIT, -SCALED_LIMIT
    for name, value in rel.items():
        lo, hi = ranges[name]
        scaled = value / hi if value >= 0 else value / -lo
        # max(low, min(high, scaled)), the same comparisons (NaN included)
        capped = scaled if scaled < high else high
        out[name] = capped if capped > low else low
    return out
