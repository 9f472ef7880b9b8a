"""A real neutral face and known edits of it, for the named-feature tests (not a test module).

``face_neutral.npz`` holds the sample video's first second (F's neutral window, docs/method.md)
as the tracker saw it: the median of its 24 meshes (each aligned onto the first on stable
vertices), turned to face the camera squarely (its own face frame) and placed at 150 px per
inter-ocular distance (outer eye corners at (245, 160) and (395, 160)); z in the same pixels,
away from the camera. The 10 iris points keep their median position in each eye's corner frame.
The 68 points are derived from the mesh with P's own vertex table, as the tracker does.

Edits are in the face frame (IOD units, x toward the performer's left = image right, y up =
image up); rotations use the contract's yaw/pitch/roll.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from facesynth.schemas.messages import Points, PointSet
from facesynth.services.features.pose import apply, own_frame
from facesynth.services.points.tracker.ibug68 import load_mapping
from facesynth.services.points.tracker.iris import EYE_CONTOUR_VERTICES


def to_face_frame(mesh: np.ndarray) -> np.ndarray:
    """A mesh in its own face frame (IOD units, x toward the performer's left, y up)."""
    return apply(own_frame(mesh), mesh)


def rotation_from_euler(yaw: float, pitch: float, roll: float) -> np.ndarray:
    """The face-frame rotation with these angles in degrees (inverse of ``pose.euler_degrees``)."""
    a, b, g = math.radians(yaw), -math.radians(pitch), -math.radians(roll)
    ry = np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])
    rx = np.array([[1, 0, 0], [0, math.cos(b), -math.sin(b)], [0, math.sin(b), math.cos(b)]])
    rz = np.array([[math.cos(g), -math.sin(g), 0], [math.sin(g), math.cos(g), 0], [0, 0, 1]])
    result: np.ndarray = ry @ rx @ rz
    return result


FIXTURE = Path(__file__).with_name("face_neutral.npz")
_DATA = np.load(FIXTURE)
MESH: np.ndarray = _DATA["mesh"]
IRIS: np.ndarray = _DATA["iris"]
PX = 150.0  # pixels per inter-ocular distance
S = 1_000_000_000

_W = np.zeros((68, 468))
for _i, (_vertices, _weights) in enumerate(load_mapping()):
    _W[_i, _vertices] = _weights

# face frame <-> mesh coordinates (x right, y down, z away): flip y and z
_FLIP = np.diag([1.0, -1.0, -1.0])


def ibug_of(mesh: np.ndarray) -> np.ndarray:
    """The 68 points of a mesh, as the tracker derives them (float64)."""
    result: np.ndarray = _W @ mesh[:, :2]
    return result


def move(mesh: np.ndarray, vertices, dx: float = 0.0, dy: float = 0.0) -> np.ndarray:
    """A copy of the mesh with ``vertices`` moved by (dx, dy) IOD in the face frame."""
    out = mesh.copy()
    idx = np.asarray(sorted(set(vertices)))
    out[idx, 0] += dx * PX
    out[idx, 1] -= dy * PX
    return out


def look(mesh: np.ndarray, iris: np.ndarray, side: str, dx: float, dy: float) -> np.ndarray:
    """A copy of the iris points with one eye's iris moved in that eye's own frame: ``dx`` eye
    widths along its corner line toward the performer's left, ``dy`` up, perpendicular."""
    a, b = (33, 133) if side == "right" else (362, 263)
    axis = mesh[b, :2] - mesh[a, :2]
    up = np.array([axis[1], -axis[0]])
    out = iris.copy()
    rows = slice(0, 5) if side == "right" else slice(5, 10)
    out[rows] += dx * axis + dy * up
    return out


def _eye_geometry(mesh: np.ndarray, side: str):
    """Corners (mesh coordinates), face transform, and the face's up / forward directions."""
    a, b = (33, 133) if side == "right" else (362, 263)
    scale, rotation, shift = own_frame(mesh)
    return mesh[a], mesh[b], (scale, rotation, shift), rotation[1], rotation[2]


def iris_3d(mesh: np.ndarray, iris: np.ndarray) -> np.ndarray:
    """Iris points lifted to 3D into the eye's opening: the plane through the eye's corners
    spanned by the corner line and the face's up direction, moved forward to the eye contour's
    mean depth (the model F reads gaze with)."""
    out = np.column_stack([iris, np.zeros(10)])
    for eye, side, rows in ((0, "right", slice(0, 5)), (1, "left", slice(5, 10))):
        a, b, _, up, forward = _eye_geometry(mesh, side)
        middle = (a + b) / 2
        contour = mesh[list(EYE_CONTOUR_VERTICES[eye])]
        origin = middle + ((contour.mean(axis=0) - middle) @ forward) * forward
        normal = np.cross(b - a, up)
        out[rows, 2] = origin[2] - (iris[rows] - origin[:2]) @ normal[:2] / normal[2]
    return out


def look_3d(mesh: np.ndarray, iris: np.ndarray, side: str, dx: float, dy: float) -> np.ndarray:
    """A copy of the iris points with one eye's iris moved in the eye's opening by ``dx`` eye
    widths along the eye's 3D corner line and ``dy`` up (as read in the face frame)."""
    a, b, (_, rotation, _), _, _ = _eye_geometry(mesh, side)
    axis = (b - a) @ rotation.T  # in the face frame (scale cancels in the gaze)
    width = float(np.linalg.norm(axis))
    ex = axis / width
    up = np.array([0.0, 1.0, 0.0]) - ex[1] * ex
    ey = up / np.linalg.norm(up)
    move_3d = (dx * ex + dy * ey) * width @ rotation  # back to mesh coordinates
    out = iris.copy()
    rows = slice(0, 5) if side == "right" else slice(5, 10)
    out[rows] += move_3d[:2]
    return out


def transform(
    mesh: np.ndarray,
    iris: np.ndarray,
    *,
    yaw: float = 0.0,
    pitch: float = 0.0,
    roll: float = 0.0,
    scale: float = 1.0,
    shift: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> tuple[np.ndarray, np.ndarray]:
    """The face turned by (yaw, pitch, roll) degrees about its centre, scaled and shifted.

    The image is the orthographic view of the 3D points (drop z), like the mesh's own x, y.
    """
    rotation = _FLIP @ rotation_from_euler(yaw, pitch, roll) @ _FLIP
    centre = mesh.mean(axis=0)
    lifted = iris_3d(mesh, iris)
    new_mesh = scale * (mesh - centre) @ rotation.T + centre + np.asarray(shift)
    new_iris = scale * (lifted - centre) @ rotation.T + centre + np.asarray(shift)
    return new_mesh, new_iris[:, :2]


def points_message(
    mesh: np.ndarray | None = MESH,
    iris: np.ndarray | None = IRIS,
    *,
    ibug: np.ndarray | None = None,
    seq: int = 0,
    t_media_ns: int = 0,
    face: bool = True,
    mesh_dims: int = 3,
) -> Points:
    """A Points message as P sends it (ibug68 from the mesh unless given)."""
    sets = []
    if face:
        if ibug is None:
            assert mesh is not None
            ibug = ibug_of(mesh)
        sets.append(PointSet(scheme="ibug68", dims=2, coords=ibug.ravel().tolist()))
        if mesh is not None:
            coords = mesh[:, :mesh_dims].ravel().tolist()
            sets.append(PointSet(scheme="mesh468", dims=mesh_dims, coords=coords))
        if iris is not None:
            sets.append(PointSet(scheme="iris10", dims=2, coords=iris.ravel().tolist()))
    return Points(
        seq=seq,
        t_capture_ns=1000 + seq,
        t_media_ns=t_media_ns,
        face=face,
        confidence=0.9 if face else 0.0,
        image_width=640,
        image_height=360,
        sets=sets,
    )


def make_fixture(path: Path = FIXTURE) -> None:
    """Regenerate ``face_neutral.npz`` from the sample video (not run by the tests); the
    result is identical to the file's contents."""
    import cv2

    from facesynth.app.data import sample_video
    from facesynth.runtime.frames import encode_frame
    from facesynth.services.features.gaze import IRIS_CENTRE, MESH_EYE_CORNERS, eye_gaze
    from facesynth.services.features.pose import median_mesh
    from facesynth.services.points.backends.tracker import TrackerBackend, TrackerConfig

    capture = cv2.VideoCapture(str(sample_video()))
    backend, meshes, irises = TrackerBackend(TrackerConfig(model="fast")), [], []
    while len(meshes) < 24:  # the first second at 23.98 fps
        _, image = capture.read()
        frame = encode_frame(image, seq=0, t_capture_ns=0, t_media_ns=0, encoding="raw")
        points = backend.process(frame)
        sets = {s.scheme: np.reshape(s.coords, (-1, s.dims)) for s in points.sets}
        meshes.append(sets["mesh468"])
        irises.append(sets["iris10"])
    capture.release()
    canon = to_face_frame(median_mesh(meshes))
    mesh = np.column_stack([320 + PX * canon[:, 0], 160 - PX * canon[:, 1], -PX * canon[:, 2]])
    iris = np.zeros((10, 2))
    for side in ("right", "left"):
        a, b = MESH_EYE_CORNERS[side]
        for j in range(IRIS_CENTRE[side], IRIS_CENTRE[side] + 5):
            local = np.median(
                [eye_gaze(i[j], m[a, :2], m[b, :2]) for m, i in zip(meshes, irises, strict=True)],
                axis=0,
            )
            axis = mesh[b, :2] - mesh[a, :2]
            up = np.array([axis[1], -axis[0]])
            iris[j] = (mesh[a, :2] + mesh[b, :2]) / 2 + local[0] * axis + local[1] * up
    np.savez(path, mesh=mesh, iris=iris)
