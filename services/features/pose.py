"""Head pose and the pose-free face frame of the 468-vertex mesh (pure numpy).

The face frame: origin midway between the outer eye corners (mesh vertices 33 and 263), x axis
along the eye line toward the performer's left, y axis up (from the base of the nose, vertex 2,
toward the nasion, vertex 168, made orthogonal to x), z = x × y toward the camera (the way the
face looks); unit = inter-ocular distance (IOD) of the outer eye corners. Mesh coordinates are
image pixels (x right, y down) with z away from the camera, a right-handed frame like the face
frame, so mapping one to the other is a proper rotation.

Head pose is the rotation from the neutral mesh to the current one, fitted (Kabsch/Umeyama, with
scale) on vertices that expressions hardly move: forehead, nose bridge, eye corners, cheekbones.
The same fit maps the current mesh onto the neutral's face frame, so expression features read
from the aligned mesh do not change when the head turns.

Angles, in degrees, as ``facesynth.runtime.feature_names`` defines them: yaw positive = head turned
toward the performer's left; pitch positive = chin up; roll positive = head tilted toward the
performer's left shoulder. They are intrinsic yaw (about y), then pitch (about x), then roll
(about z).
"""

from __future__ import annotations

import functools
import importlib
import math
from typing import Any, Final

import numpy as np

from facesynth.runtime.ibug_mesh import mesh_to_ibug68
from facesynth.services.features.frame import FeatureError

N_MESH: Final = 468

#: Outer eye corners (performer's right, left), the base of the nose and the nasion.
MESH_RIGHT_EYE_OUTER: Final = 33
MESH_LEFT_EYE_OUTER: Final = 263
MESH_NOSE_BASE: Final = 2
MESH_NASION: Final = 168

#: Vertices expressions hardly move: forehead, nose bridge and tip, eye corners, cheekbones and
#: the sides of the face at eye level. Mirror-symmetric (each pair appears on both sides).
STABLE_VERTICES: Final[tuple[int, ...]] = (
    # forehead (midline, then pairs)
    10,
    151,
    9,
    109,
    338,
    67,
    297,
    # nose bridge and tip
    168,
    6,
    197,
    195,
    5,
    4,
    # eye corners (outer, inner)
    33,
    263,
    133,
    362,
    # cheekbones and the sides of the face at eye level
    234,
    454,
    127,
    356,
    116,
    345,
    143,
    372,
)

#: Below this the fitted scale (or a reference's IOD) means a collapsed face.
MIN_SCALE: Final = 1e-6


class PoseError(FeatureError):
    """A mesh from which no face frame or pose can be computed."""


def face_axes(mesh: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """The face frame of a (468, 3) mesh: origin (3,), axes (3, 3) as rows x, y, z, and IOD."""
    right, left = mesh[MESH_RIGHT_EYE_OUTER], mesh[MESH_LEFT_EYE_OUTER]
    eye_line = left - right
    iod = float(np.linalg.norm(eye_line))
    if not np.isfinite(iod) or iod < MIN_SCALE:
        raise PoseError(f"mesh eye corners are {iod:.3g} px apart: no face frame")
    x = eye_line / iod
    # Image y points down: "up" is from the nose base toward the nasion.
    up = mesh[MESH_NASION] - mesh[MESH_NOSE_BASE]
    up = up - float(up @ x) * x
    norm = float(np.linalg.norm(up))
    if not np.isfinite(norm) or norm < MIN_SCALE:
        raise PoseError("mesh nose is degenerate: no face frame")
    y = up / norm
    # x right, y down, z away is right-handed, so is (x, y, x × y); here x × y faces the camera.
    z = np.cross(x, y)
    return (right + left) / 2.0, np.stack([x, y, z]), iod


#: A similarity transform (scale, rotation, shift): ``points -> scale * points @ R.T + shift``.
Similarity = tuple[float, np.ndarray, np.ndarray]


def apply(transform: Similarity, points: np.ndarray) -> np.ndarray:
    """Points mapped by a similarity transform."""
    scale, rotation, shift = transform
    result: np.ndarray = scale * points @ rotation.T + shift
    return result


def own_frame(mesh: np.ndarray) -> Similarity:
    """The transform from mesh coordinates to the mesh's own face frame."""
    origin, axes, iod = face_axes(mesh)
    return 1.0 / iod, axes, -(origin @ axes.T) / iod


def _det3(m: np.ndarray) -> float:
    """Determinant of a 3x3 matrix (cheaper than np.linalg.det for one small matrix)."""
    (a, b, c), (d, e, f), (g, h, i) = m.tolist()
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)


def _lapack_svd() -> Any:
    """The LAPACK gufunc behind ``np.linalg.svd`` (numpy 1.26 and 2.x), or None elsewhere."""
    try:
        return importlib.import_module("numpy.linalg._umath_linalg").svd_f
    except (ImportError, AttributeError):
        return None


_SVD_F = _lapack_svd()


def svd3(matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``np.linalg.svd`` of a real (3, 3) float64 matrix (or a stack of them), bit for bit: the
    same LAPACK call without the wrapper's checks, which cost more than the decomposition of
    so small a matrix. A decomposition that does not converge (a matrix that is not finite)
    gives NaN here where numpy raises: the fits' scale check turns it into a
    :class:`PoseError`."""
    if _SVD_F is None:
        u, sigma, vt = np.linalg.svd(matrix)
    else:
        with np.errstate(all="ignore"):  # numpy's own svd ignores all but non-convergence
            u, sigma, vt = _SVD_F(matrix, signature="d->ddd")
    return u, sigma, vt


def _centred(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The mean of (n, 3) points (bit for bit ``points.mean(axis=0)``, without its wrapper's
    cost) and the points less it."""
    mean: np.ndarray = np.add.reduce(points, axis=0) / len(points)
    return mean, points - mean


class FitTarget:
    """Points a similarity fit maps onto, centred once: a neutral's stable vertices are the
    target of every frame's fit, so their mean is not taken again each frame."""

    __slots__ = ("centred", "mean")

    def __init__(self, target: np.ndarray) -> None:
        self.mean, self.centred = _centred(target)


def _fit_source(source: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """A fit's source points: their mean, the points less it, their variance (checked)."""
    mean, centred = _centred(source)
    variance = float((centred * centred).sum())
    if not math.isfinite(variance) or variance < MIN_SCALE:
        raise PoseError("the stable mesh vertices are collapsed: no pose")
    return mean, centred, variance


def _similarity(
    svd: tuple[np.ndarray, np.ndarray, np.ndarray],
    source: tuple[np.ndarray, np.ndarray, float],
    target: FitTarget,
) -> Similarity:
    """The fit from the SVD of the target's centred points (transposed) times the source's."""
    u, sigma, vt = svd
    mean_s, _, var_s = source
    rotation = u @ vt
    if _det3(rotation) < 0:  # a reflection: flip the least significant axis
        d = np.array([1.0, 1.0, -1.0])
        rotation = (u * d) @ vt
        sigma = sigma * d
    scale = float(sigma.sum()) / var_s
    if not scale > MIN_SCALE:
        raise PoseError("the fitted mesh scale is not positive: no pose")
    return scale, rotation, target.mean - scale * mean_s @ rotation.T


def similarity_fit(source: np.ndarray, target: np.ndarray | FitTarget) -> Similarity:
    """Scale, rotation and translation with ``target ≈ scale * source @ rotation.T + shift``.

    Least squares (Umeyama 1991); the rotation is proper (no reflection). ``target`` may be
    given centred already (:class:`FitTarget`): the same fit, bit for bit.
    """
    if not isinstance(target, FitTarget):
        target = FitTarget(target)
    points = _fit_source(source)
    return _similarity(svd3(target.centred.T @ points[1]), points, target)


def euler_degrees(rotation: np.ndarray) -> tuple[float, float, float]:
    """(yaw, pitch, roll) in degrees of a rotation of the face frame (see the module doc)."""
    r = rotation.tolist()
    yaw = math.atan2(r[0][2], r[2][2])
    about_x = math.asin(max(-1.0, min(1.0, -r[1][2])))
    about_z = math.atan2(r[1][0], r[1][1])
    # Positive rotation about x turns the face down and about z tilts the top toward -x (the
    # performer's right): the contract's pitch and roll are the opposite.
    return math.degrees(yaw), -math.degrees(about_x), -math.degrees(about_z)


#: The face frame of a face looking straight at the camera, as rows in mesh coordinates.
FRONTAL_AXES: Final = np.diag([1.0, -1.0, -1.0])


def camera_pose(mesh: np.ndarray) -> tuple[float, float, float]:
    """(yaw, pitch, roll) of a mesh's face frame against the camera's axes (no neutral)."""
    _, axes, _ = face_axes(mesh)
    return euler_degrees(FRONTAL_AXES @ axes.T)


class MeshReference:
    """A neutral mesh prepared for aligning others onto its face frame."""

    def __init__(self, neutral_mesh: np.ndarray) -> None:
        mesh = np.asarray(neutral_mesh, dtype=np.float64)
        if mesh.shape != (N_MESH, 3) or not np.all(np.isfinite(mesh)):
            raise PoseError(f"a neutral mesh needs ({N_MESH}, 3) finite values")
        self.mesh = mesh
        origin, self.axes, self.iod = face_axes(mesh)
        self.canonical: np.ndarray = (mesh - origin) @ self.axes.T / self.iod
        self._stable = np.asarray(STABLE_VERTICES)
        self._target = FitTarget(self.canonical[self._stable])
        #: The neutral mesh's own stable vertices, the target of ``frontal.frontalized``'s fit.
        self.stable_target = FitTarget(mesh[self._stable])
        #: Both targets' centred points, transposed and stacked, for :meth:`fits`.
        self._targets_t = np.stack([self.stable_target.centred.T, self._target.centred.T])

    @functools.cached_property
    def ibug68(self) -> np.ndarray:
        """The neutral's 68 iBUG points (68, 2), through the tracker's vertex table."""
        points: np.ndarray = mesh_to_ibug68(self.mesh).astype(np.float64)
        return points

    def fit(self, mesh: np.ndarray) -> Similarity:
        """The transform from a mesh's coordinates onto the neutral's face frame."""
        return similarity_fit(mesh[self._stable], self._target)

    def fits(self, mesh: np.ndarray) -> tuple[Similarity, Similarity]:
        """Both fits of a mesh: onto the neutral mesh's own coordinates (``frontal``'s,
        ``similarity_fit(mesh[STABLE_VERTICES], self.stable_target)``) and onto its face frame
        (:meth:`fit`), each bit for bit as alone, from one centring of the mesh's stable
        vertices and one SVD call for the two (F needs both every frame)."""
        source = _fit_source(mesh[self._stable])
        u, sigma, vt = svd3(self._targets_t @ source[1])
        return (
            _similarity((u[0], sigma[0], vt[0]), source, self.stable_target),
            _similarity((u[1], sigma[1], vt[1]), source, self._target),
        )

    def head_rotation(self, transform: Similarity) -> np.ndarray:
        """The head rotation from the neutral, in the face frame, of a :meth:`fit` result
        (:func:`euler_degrees` gives the head pose relative to the neutral)."""
        # If current = Q @ neutral (mesh coordinates), rotation = axes @ Q.T, so the head
        # rotation in face-frame coordinates, axes @ Q @ axes.T, is axes @ rotation.T.
        head: np.ndarray = self.axes @ transform[1].T
        return head

    def align(self, mesh: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The mesh in the neutral's face frame, and the head rotation from the neutral."""
        transform = self.fit(mesh)
        return apply(transform, mesh), self.head_rotation(transform)


def unturned(points: np.ndarray, mesh: np.ndarray) -> np.ndarray:
    """Image points with their depth, (n, 3), turned out of the head's yaw; their x, y (n, 2).

    The points are turned about the image's vertical axis through the eye corners' midpoint
    until the face (the z axis of ``mesh``'s :func:`face_axes`) looks neither left nor right: a
    face turned to one side looks as if it faced the camera, with its pitch and roll as they
    were (the contract's yaw is the first of yaw, pitch, roll: undoing it leaves the other two).
    The paper's 2D features then read these points as they read the image's.

    Only the yaw is undone. Undoing the pitch too (the whole face frame) over-corrects with the
    tracker's depth: on the bundled video's laugh the frontalised nose tip drops 0.011 IOD per
    degree of chin-up, so the brow-to-nose distances grew 0.005-0.007 IOD per degree (2D: they
    shrink about as much). Undoing the yaw alone takes the yaw's own effect on the brows'
    distances (2D: up to 0.008 IOD per degree, shorter on the side turned away) to 0.002 or
    less there.
    """
    origin, axes, _ = face_axes(mesh)
    facing = axes[2]  # toward the camera: negative depth
    if abs(float(facing[2])) < MIN_SCALE or facing[2] > 0:
        raise PoseError("the face does not face the camera: no yaw to undo")
    # Turning by ``angle`` about the image's y axis takes the facing's x to x cos + z sin.
    angle = math.atan(-float(facing[0]) / float(facing[2]))
    cos, sin = math.cos(angle), math.sin(angle)
    rotation = np.array([[cos, 0.0, sin], [0.0, 1.0, 0.0], [-sin, 0.0, cos]])
    turned: np.ndarray = ((points - origin) @ rotation.T)[:, :2] + origin[:2]
    return turned


def roll_2d(right_eye_outer: np.ndarray, left_eye_outer: np.ndarray) -> float:
    """Head roll in degrees from the image eye line (image y down; positive = toward the left
    shoulder, which lowers the performer's left eye, on the image's right)."""
    dx, dy = left_eye_outer[:2] - right_eye_outer[:2]
    return math.degrees(math.atan2(dy, dx))


def median_mesh(meshes: list[np.ndarray]) -> np.ndarray:
    """The element-wise median of meshes after aligning each onto the first (its coordinates)."""
    if not meshes:
        raise PoseError("no meshes to take a median of")
    first = np.asarray(meshes[0], dtype=np.float64)
    stable = np.asarray(STABLE_VERTICES)
    aligned = [first]
    for mesh in meshes[1:]:
        scale, rotation, shift = similarity_fit(mesh[stable], first[stable])
        aligned.append(scale * mesh @ rotation.T + shift)
    result: np.ndarray = np.median(np.stack(aligned), axis=0)
    return result
