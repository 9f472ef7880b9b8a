"""A frame's pixels as the tracker reads them (RGBA), a JPEG decoded straight to RGBA.

The tracker crops and warps an RGBA frame (:func:`.model_input.frame_to_rgba`). OpenCV decodes
a JPEG only to BGR (and first reads its EXIF block for an orientation), so P paid for a decode
into BGR and then for a colour conversion of the whole frame. simplejpeg runs libjpeg-turbo,
the decoder OpenCV bundles, with the same settings (accurate integer IDCT, smooth chroma
upsampling) and asks it for RGBA directly: the same pixels for 15-17 % less CPU (0.17-0.21 ms
a frame of the bundled video, on a loaded host). ``tests/points/tracker/test_tracker_jpeg_rgba.py``
holds the pixels equal, frame by frame, on the bundled video and on JPEGs of every chroma
subsampling.

Where simplejpeg would not give exactly what OpenCV gives, OpenCV decodes as before:

* a JPEG with an EXIF block (OpenCV turns the image by its orientation tag);
* a JPEG that libjpeg-turbo decodes only with a warning (cut short, corrupt data: strict mode
  refuses it) or not at all (CMYK), so OpenCV's result or its error stays the answer;
* raw frames, and hosts without simplejpeg.
"""

from __future__ import annotations

import numpy as np

from facesynth.runtime.frames import FrameError, decode_frame
from facesynth.schemas.messages import Frame

from .model_input import frame_to_rgba

try:
    import simplejpeg
except ImportError:  # an install without it: OpenCV decodes, the same pixels, more slowly
    simplejpeg = None

__all__ = ["decode_rgba"]

#: The tag of an EXIF block (APP1): OpenCV applies its orientation, libjpeg-turbo does not.
EXIF = b"Exif\x00\x00"


def decode_rgba(frame: Frame, out: np.ndarray | None = None) -> np.ndarray:
    """The uint8 RGBA image (H, W, 4) of a frame with pixels: the pixels of
    :func:`facesynth.runtime.frames.decode_frame` then :func:`.model_input.frame_to_rgba`.

    ``out`` is written and returned when it is a C-contiguous uint8 buffer of the right shape.

    Raises:
        FrameError: the pixels cannot be decoded, or differ in size from the frame's header.
    """
    if out is not None and (
        out.shape != (frame.height, frame.width, 4)
        or out.dtype != np.uint8
        or not out.flags.c_contiguous
    ):
        out = None
    if simplejpeg is not None and frame.encoding == "jpeg" and frame.data.find(EXIF) < 0:
        try:
            image = simplejpeg.decode_jpeg(
                frame.data,
                colorspace="RGBA",
                fastdct=False,
                fastupsample=False,
                strict=True,
                buffer=out,
            )
        except ValueError:
            pass  # OpenCV decodes it, or says why not
        else:
            if image.shape[:2] != (frame.height, frame.width):
                raise FrameError(
                    f"frame {frame.seq}: JPEG is {image.shape[1]}x{image.shape[0]}, "
                    f"header says {frame.width}x{frame.height}"
                )
            return image
    return frame_to_rgba(decode_frame(frame), out)
