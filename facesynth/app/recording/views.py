"""Foxglove's well-known views of facesynth messages: the frame as an image, landmarks over it.

Encoded as protobuf with the ``foxglove-sdk`` package's own message classes and schemas, so
Foxglove's Image panel shows the performer's frame (``foxglove.CompressedImage`` for JPEG,
``foxglove.RawImage`` for raw BGR) with the tracked points drawn over it
(``foxglove.ImageAnnotations``). Both carry the frame's capture time as their timestamp, which
is how the Image panel pairs annotations with their image.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from functools import cache
from typing import Any

from foxglove import messages as fg

from facesynth.runtime.landmarks import IBUG68, IRIS10, MESH468, MESH478
from facesynth.schemas.messages import Frame, Points, PointSet


@dataclass(frozen=True)
class SchemaSpec:
    """A channel schema: name, encoding (``jsonschema``, ``protobuf``) and its bytes."""

    name: str
    encoding: str
    data: bytes


#: Frame id of every image and annotation (Foxglove groups images by it).
FRAME_ID = "camera"

#: Polylines of the 68-point scheme: (first, last, closed). Right/left are the performer's.
IBUG68_OUTLINES: tuple[tuple[int, int, bool], ...] = (
    (0, 16, False),  # jaw
    (17, 21, False),  # right brow
    (22, 26, False),  # left brow
    (27, 30, False),  # nose bridge
    (31, 35, False),  # nose base
    (36, 41, True),  # right eye
    (42, 47, True),  # left eye
    (48, 59, True),  # outer lips
    (60, 67, True),  # inner lips
)

_GREEN = fg.Color(r=0.1, g=0.9, b=0.3, a=1.0)
_CYAN = fg.Color(r=0.1, g=0.8, b=1.0, a=1.0)
_GREY = fg.Color(r=0.8, g=0.8, b=0.8, a=0.6)


@cache
def _schema(cls: Any) -> SchemaSpec:
    schema = cls.get_schema()
    return SchemaSpec(schema.name, schema.encoding, bytes(schema.data))


def compressed_image_schema() -> SchemaSpec:
    """The ``foxglove.CompressedImage`` protobuf schema."""
    return _schema(fg.CompressedImage)


def raw_image_schema() -> SchemaSpec:
    """The ``foxglove.RawImage`` protobuf schema."""
    return _schema(fg.RawImage)


def annotations_schema() -> SchemaSpec:
    """The ``foxglove.ImageAnnotations`` protobuf schema."""
    return _schema(fg.ImageAnnotations)


def _timestamp(t_ns: int) -> fg.Timestamp:
    return fg.Timestamp(t_ns // 1_000_000_000, t_ns % 1_000_000_000)


def image_view(frame: Frame) -> tuple[SchemaSpec, bytes] | None:
    """The frame's pixels as a Foxglove image, or ``None`` for a tick without pixels."""
    stamp = _timestamp(frame.t_capture_ns)
    if frame.encoding == "jpeg":
        image = fg.CompressedImage(
            timestamp=stamp, frame_id=FRAME_ID, data=frame.data, format="jpeg"
        )
        return compressed_image_schema(), image.encode()
    if frame.encoding == "raw":
        raw = fg.RawImage(
            timestamp=stamp,
            frame_id=FRAME_ID,
            width=frame.width,
            height=frame.height,
            encoding="bgr8",
            step=frame.width * 3,
            data=frame.data,
        )
        return raw_image_schema(), raw.encode()
    return None


def _shape(
    stamp: fg.Timestamp,
    kind: fg.PointsAnnotationType,
    point_set: PointSet,
    indices: Iterable[int],
    color: fg.Color,
    thickness: float,
) -> fg.PointsAnnotation:
    """The points ``indices`` of ``point_set`` drawn as ``kind``."""
    coords, dims = point_set.coords, point_set.dims
    return fg.PointsAnnotation(
        timestamp=stamp,
        type=kind,
        points=[fg.Point2(x=coords[i * dims], y=coords[i * dims + 1]) for i in indices],
        outline_color=color,
        thickness=thickness,
    )


def annotations_view(points: Points) -> tuple[SchemaSpec, bytes]:
    """The tracked landmarks as Foxglove image annotations (empty when there is no face).

    The 68 points are drawn as the face's outlines, the iris points as dots; a stream with only
    the mesh shows the mesh as dots.
    """
    stamp = _timestamp(points.t_capture_ns)
    shapes: list[fg.PointsAnnotation] = []
    sets = {point_set.scheme: point_set for point_set in points.sets}
    ibug = sets.get(IBUG68)
    kinds = fg.PointsAnnotationType
    if ibug is not None and len(ibug.coords) >= 68 * ibug.dims:
        for first, last, closed in IBUG68_OUTLINES:
            kind = kinds.LineLoop if closed else kinds.LineStrip
            shapes.append(_shape(stamp, kind, ibug, range(first, last + 1), _GREEN, 2.0))
    elif MESH468 in sets or MESH478 in sets:
        mesh = sets.get(MESH468) or sets[MESH478]
        shapes.append(
            _shape(stamp, kinds.Points, mesh, range(len(mesh.coords) // mesh.dims), _GREY, 2.0)
        )
    iris = sets.get(IRIS10)
    if iris is not None:
        shapes.append(
            _shape(stamp, kinds.Points, iris, range(len(iris.coords) // iris.dims), _CYAN, 4.0)
        )
    return annotations_schema(), fg.ImageAnnotations(timestamp=stamp, points=shapes).encode()
