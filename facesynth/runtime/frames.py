"""Frame pixels to and from :class:`facesynth.schemas.messages.Frame` (JPEG or raw BGR).

With the sensor's default encoding, :data:`AUTO`, the stages of the sensor's own process take
its raw pixels (:func:`local_encoding`), and every other reader (a process elsewhere, a
recorder) gets the same frame as JPEG (:func:`jpeg_form`), encoded once, only when one wants
bytes.
"""

from __future__ import annotations

import msgspec
import numpy as np

from facesynth.runtime.opencv import import_cv2
from facesynth.schemas.messages import Frame

#: A nominal image size for frames without pixels (ticks).
TICK_SIZE = (640, 480)

#: The sensor's default: raw pixels to the stages of its process, JPEG to every other reader.
AUTO = "auto"


class FrameError(ValueError):
    """A frame whose pixels cannot be encoded or decoded."""


def encode_frame(
    image: np.ndarray,
    *,
    seq: int,
    t_capture_ns: int,
    t_media_ns: int,
    encoding: str = "jpeg",
    quality: int = 90,
    source: str = "",
    fps: float = 0.0,
) -> Frame:
    """A Frame message holding ``image`` (H x W x 3, BGR uint8)."""
    if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
        raise FrameError(f"need an HxWx3 uint8 BGR image, got {image.shape} {image.dtype}")
    height, width = image.shape[:2]
    if encoding == "jpeg":
        cv2 = import_cv2(FrameError)
        ok, buffer = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
        if not ok:
            raise FrameError("JPEG encoding failed")
        data = buffer.tobytes()
    elif encoding == "raw":
        data = np.ascontiguousarray(image).tobytes()
    else:
        raise FrameError(f"unknown frame encoding {encoding!r} (use jpeg or raw)")
    return Frame(
        seq=seq,
        t_capture_ns=t_capture_ns,
        t_media_ns=t_media_ns,
        width=width,
        height=height,
        encoding=encoding,  # type: ignore[arg-type]
        data=data,
        source=source,
        fps=fps,
    )


def local_encoding(encoding: str) -> str:
    """The encoding of the frames a stage in the sensor's own process takes, for the sensor's
    ``encoding`` (``jpeg``, ``raw`` or :data:`AUTO`, whose frames are raw there)."""
    return "raw" if encoding == AUTO else encoding


def jpeg_form(frame: Frame, quality: int) -> Frame:
    """A raw frame as JPEG at ``quality`` (every other field the same), as the sensor would have
    encoded its pixels; any other frame as it is. :class:`FrameError` if its pixels are not
    those of its header."""
    if frame.encoding != "raw":
        return frame
    jpeg = encode_frame(
        decode_frame(frame), seq=frame.seq, t_capture_ns=0, t_media_ns=0, quality=quality
    )
    return msgspec.structs.replace(frame, encoding="jpeg", data=jpeg.data)


def tick_frame(
    *, seq: int, t_capture_ns: int, t_media_ns: int, source: str = "", fps: float = 0.0
) -> Frame:
    """A Frame message without pixels (a tick: replayed point streams need only its clock)."""
    width, height = TICK_SIZE
    return Frame(
        seq=seq,
        t_capture_ns=t_capture_ns,
        t_media_ns=t_media_ns,
        width=width,
        height=height,
        encoding="none",
        source=source,
        fps=fps,
    )


def decode_frame(frame: Frame) -> np.ndarray:
    """The BGR image of a frame, or raise :class:`FrameError` (e.g. a corrupt JPEG)."""
    if frame.encoding == "raw":
        expected = frame.width * frame.height * 3
        if len(frame.data) != expected:
            raise FrameError(f"raw frame needs {expected} bytes, got {len(frame.data)}")
        return np.frombuffer(frame.data, dtype=np.uint8).reshape(frame.height, frame.width, 3)
    if frame.encoding == "jpeg":
        cv2 = import_cv2(FrameError)
        if not frame.data:
            raise FrameError(f"frame {frame.seq}: JPEG data cannot be decoded")
        image = cv2.imdecode(np.frombuffer(frame.data, dtype=np.uint8), cv2.IMREAD_COLOR)
        if image is None:
            raise FrameError(f"frame {frame.seq}: JPEG data cannot be decoded")
        if image.shape[:2] != (frame.height, frame.width):
            raise FrameError(
                f"frame {frame.seq}: JPEG is {image.shape[1]}x{image.shape[0]}, "
                f"header says {frame.width}x{frame.height}"
            )
        return image
    raise FrameError(f"frame {frame.seq} has no pixels (encoding {frame.encoding!r})")
