"""facesynth.services.sensor.sources.ros2_images: ROS 2 image fields as frames, without rclpy.

JPEG CompressedImage is passed through byte for byte; Image in bgr8, rgb8 and mono8 becomes
the same BGR pixels, row padding (``step``) cut off; any other encoding or compressed format is
refused in one line naming those taken; a message whose fields do not hold together is a
:class:`BadImage` (dropped by the source).
"""

from __future__ import annotations

import numpy as np
import pytest

from facesynth.runtime.opencv import import_cv2
from facesynth.services.sensor.sources.base import JpegImage, SourceError
from facesynth.services.sensor.sources.ros2_images import (
    BadImage,
    UnsupportedImage,
    capture_time,
    compressed_image,
    raw_image,
    stamp_clock,
    trusted_stamp,
)

cv2 = import_cv2(RuntimeError)
RNG = np.random.default_rng(7)
BGR = RNG.integers(0, 256, (6, 5, 3), dtype=np.uint8)


def test_a_jpeg_is_passed_through_as_it_is() -> None:
    jpeg = bytes(cv2.imencode(".jpg", np.full((24, 40, 3), 90, np.uint8))[1])
    assert compressed_image("jpeg", jpeg) == JpegImage(jpeg, 40, 24)
    assert compressed_image("rgb8; jpeg compressed bgr8", jpeg + b"\r\n").data == jpeg


def test_a_png_is_refused_in_one_line() -> None:
    png = bytes(cv2.imencode(".png", BGR)[1])
    with pytest.raises(UnsupportedImage) as caught:
        compressed_image("png", png)
    assert str(caught.value) == (
        "a CompressedImage in format 'png' is not a JPEG: the ros2 source takes JPEG "
        "CompressedImage, or Image in rgb8, bgr8 or mono8"
    )
    assert isinstance(caught.value, SourceError)


def test_a_jpeg_cut_short_is_dropped() -> None:
    jpeg = bytes(cv2.imencode(".jpg", BGR)[1])
    with pytest.raises(BadImage, match="cut short"):
        compressed_image("jpeg", jpeg[: len(jpeg) // 2])


@pytest.mark.parametrize("padding", [0, 3])
def test_bgr8_rgb8_and_mono8_give_bgr_pixels(padding: int) -> None:
    height, width = BGR.shape[:2]

    def padded(pixels: np.ndarray) -> tuple[int, bytes]:
        rows = pixels.reshape(height, -1)
        pad = np.zeros((height, padding), np.uint8)
        return rows.shape[1] + padding, np.hstack([rows, pad]).tobytes()

    step, data = padded(BGR)
    assert np.array_equal(raw_image("bgr8", width, height, step, data), BGR)
    step, data = padded(np.ascontiguousarray(BGR[:, :, ::-1]))
    assert np.array_equal(raw_image("rgb8", width, height, step, data), BGR)
    gray = BGR[:, :, 1]
    step, data = padded(np.ascontiguousarray(gray))
    mono = raw_image("mono8", width, height, step, data)
    assert mono.shape == (height, width, 3) and all(
        np.array_equal(mono[:, :, c], gray) for c in range(3)
    )


@pytest.mark.parametrize("encoding", ["yuv422_yuy2", "16UC1", "bgra8", "", "RGB8"])
def test_other_encodings_are_refused_in_one_line(encoding: str) -> None:
    with pytest.raises(UnsupportedImage) as caught:
        raw_image(encoding, 5, 6, 15, bytes(90))
    message = str(caught.value)
    assert message.endswith(
        ": the ros2 source takes rgb8, bgr8 or mono8 (or a JPEG CompressedImage)"
    )
    assert "\n" not in message and repr(encoding) in message


@pytest.mark.parametrize(
    ("width", "height", "step", "size", "detail"),
    [
        (5, 6, 15, 89, "holding 89 bytes, not 90"),
        (5, 6, 14, 90, "step 14 is shorter than a row (15 bytes)"),
        (0, 6, 15, 90, "an Image of 0x6 pixels"),
        (5, 0, 15, 90, "an Image of 5x0 pixels"),
        (100_000, 1, 300_000, 300_000, "an Image of 100000x1 pixels"),
    ],
    ids=["short-data", "short-step", "no-width", "no-height", "huge"],
)
def test_fields_that_do_not_hold_together_are_bad(
    width: int, height: int, step: int, size: int, detail: str
) -> None:
    with pytest.raises(BadImage) as caught:
        raw_image("bgr8", width, height, step, bytes(size))
    assert detail in str(caught.value)


def test_only_a_stamp_on_this_hosts_clock_is_a_capture_time() -> None:
    now = 1_790_000_000_000_000_000
    assert trusted_stamp(now - 40_000_000, now)  # 40 ms ago: a camera's exposure
    assert trusted_stamp(now + 4_000_000_000, now)  # a host 4 s ahead
    assert not trusted_stamp(0, now)  # not set
    assert not trusted_stamp(123_000_000_000, now)  # simulated time: 123 s
    assert not trusted_stamp(now - 6_000_000_000, now)


def test_a_cameras_stamp_is_read_on_the_cameras_clock_never_this_hosts() -> None:
    # The camera driver stamps on its machine's clock: even a stamp that agrees with this
    # host's to the nanosecond proves nothing, so the frame names the topic's clock and the
    # stages downstream learn its offset (a camera 3 s behind must not keep the face still).
    now = 1_790_000_000_000_000_000
    topic = "/robot/camera/image_raw"
    for stamp in (now - 3_000_000_000, now - 40_000_000, now, now + 4_000_000_000):
        assert capture_time(stamp, now, topic) == (stamp, "ros2:/robot/camera/image_raw")
    assert stamp_clock(topic) == "ros2:/robot/camera/image_raw" != stamp_clock("/camera/b")


@pytest.mark.parametrize("stamp", [0, 123_000_000_000, 1_790_000_000_000_000_000 - 6 * 10**9])
def test_an_image_stamped_when_taken_here_is_on_this_hosts_clock(stamp: int) -> None:
    # Not set, simulated time, a clock far off: the time taken here, which is this host's.
    now = 1_790_000_000_000_000_000
    assert capture_time(stamp, now, "/camera/image_raw") == (now, "")
