"""ROS 2 image messages as frames (pure: fields in, pixels or a JPEG out; no rclpy here).

* ``sensor_msgs/msg/CompressedImage`` holding a JPEG is passed through as it is, as the MJPEG
  camera's parts are (:class:`~facesynth.services.sensor.sources.base.JpegImage`); another format is
  refused (:class:`UnsupportedImage`).
* ``sensor_msgs/msg/Image`` in ``rgb8``, ``bgr8`` or ``mono8`` becomes BGR pixels (rows cut
  to ``width`` when ``step`` pads them); another encoding is refused in one line naming those.

A message that says one thing and holds another (too few bytes for its size, a ``step``
shorter than a row, a JPEG cut short) raises :class:`BadImage`: the source drops it.
"""

from __future__ import annotations

from typing import Final

import numpy as np

from facesynth.runtime.jpeg import JpegHeaderError
from facesynth.services.sensor.sources.base import JpegImage, SourceError
from facesynth.services.sensor.sources.mjpeg import part_image

#: ``sensor_msgs/Image`` encodings taken, and their bytes per pixel.
ENCODINGS: Final[dict[str, int]] = {"rgb8": 3, "bgr8": 3, "mono8": 1}
#: Larger images are refused (a 8K frame is 7680x4320).
MAX_SIDE: Final = 16384


#: Stamps further than this from the host's wall clock are not taken as capture times (s).
STAMP_TRUSTED_S: Final = 5.0


def trusted_stamp(stamp_ns: int, now_ns: int) -> bool:
    """Whether an image's stamp reads as this host's wall clock (within
    :data:`STAMP_TRUSTED_S` of ``now_ns``), so it can be the frame's capture time; a zero
    stamp, simulated time or a clock far off is not."""
    return abs(now_ns - stamp_ns) <= STAMP_TRUSTED_S * 1e9


def stamp_clock(topic: str) -> str:
    """The name of the clock the header stamps of ``topic`` are read on (``ros2:<topic>``), as
    a frame's ``capture_host``: the camera driver's, on a machine and clock the source cannot
    know (another host's, a few seconds off, or this one's), so never this host's name."""
    return f"ros2:{topic}"


def capture_time(stamp_ns: int, now_ns: int, topic: str) -> tuple[int, str]:
    """When an image of ``topic`` stamped ``stamp_ns`` and taken here at ``now_ns`` was
    captured, and on whose clock: its stamp on the camera's clock (:func:`stamp_clock`) when
    it reads as a wall clock (:func:`trusted_stamp`), so a receiver learns that clock's offset
    (on probation) instead of taking a camera seconds behind for its own; else ``now_ns``, the
    one time provably of this host's clock (``""``: the sensor names its own)."""
    if trusted_stamp(stamp_ns, now_ns):
        return stamp_ns, stamp_clock(topic)
    return now_ns, ""


class UnsupportedImage(SourceError):
    """An image the source does not take (an encoding or a compressed format); one line."""


class BadImage(ValueError):
    """A message whose fields do not hold together; it is dropped."""


def compressed_image(image_format: str, data: bytes) -> JpegImage:
    """A ``CompressedImage``'s JPEG, passed on as it is.

    Raises:
        UnsupportedImage: not a JPEG (a PNG, say).
        BadImage: a JPEG whose header cannot be read or that is cut short.
    """
    if not data.startswith(b"\xff\xd8"):
        raise UnsupportedImage(
            f"a CompressedImage in format {_shown(image_format)} is not a JPEG: the ros2 source "
            "takes JPEG CompressedImage, or Image in rgb8, bgr8 or mono8"
        )
    try:
        return part_image(data)
    except JpegHeaderError as exc:
        raise BadImage(f"a CompressedImage JPEG that cannot be read: {exc}") from None


def raw_image(encoding: str, width: int, height: int, step: int, data: bytes) -> np.ndarray:
    """An ``Image``'s pixels as BGR (``height x width x 3``, uint8).

    Raises:
        UnsupportedImage: an encoding other than rgb8, bgr8, mono8.
        BadImage: sizes that do not fit the data.
    """
    channels = ENCODINGS.get(encoding)
    if channels is None:
        raise UnsupportedImage(
            f"an Image in encoding {_shown(encoding)}: the ros2 source takes rgb8, bgr8 or "
            "mono8 (or a JPEG CompressedImage)"
        )
    if not (0 < width <= MAX_SIDE and 0 < height <= MAX_SIDE):
        raise BadImage(f"an Image of {width}x{height} pixels")
    row = width * channels
    if step < row:
        raise BadImage(f"an Image whose step {step} is shorter than a row ({row} bytes)")
    if len(data) < step * height:
        raise BadImage(
            f"an Image of {width}x{height} {encoding} (step {step}) holding {len(data)} bytes, "
            f"not {step * height}"
        )
    buffer = np.frombuffer(data, dtype=np.uint8, count=step * height).reshape(height, step)
    pixels = buffer[:, :row].reshape(height, width, channels)
    if encoding == "bgr8":
        return np.ascontiguousarray(pixels)
    if encoding == "rgb8":
        return np.ascontiguousarray(pixels[:, :, ::-1])
    return np.repeat(pixels, 3, axis=2)


def _shown(text: str) -> str:
    """A format or encoding from the wire, safe on one line."""
    shown = " ".join(text.split())[:40]
    return repr(shown) if shown else "''"
