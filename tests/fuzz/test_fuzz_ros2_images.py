"""Fuzz the ROS 2 image decoder (:mod:`facesynth.services.sensor.sources.ros2_images`), which reads
fields a camera on the network sends: any encoding, sizes, step and bytes, and any compressed
format and bytes (a JPEG, cut or damaged, or random). Every case gives BGR pixels of the size
the message says (or the JPEG's size), or an :class:`UnsupportedImage` / :class:`BadImage`
with a one-line message."""

from __future__ import annotations

import numpy as np
import pytest
from fuzzing import FUZZ, TIMEOUT, check_tally, outcome
from hypothesis import given
from hypothesis import strategies as st
from mutations import damaged

from facesynth.runtime.jpeg import jpeg_size
from facesynth.runtime.opencv import import_cv2
from facesynth.services.sensor.sources.ros2_images import (
    BadImage,
    UnsupportedImage,
    compressed_image,
    raw_image,
)

pytestmark = [pytest.mark.fuzz, TIMEOUT]

cv2 = import_cv2(RuntimeError)
JPEG = bytes(cv2.imencode(".jpg", np.full((8, 16, 3), 90, np.uint8))[1].tobytes())
encodings = st.one_of(st.sampled_from(["rgb8", "bgr8", "mono8", "bgra8", "16UC1"]), st.text())
sides = st.one_of(st.integers(-2, 12), st.integers(-(2**31), 2**31))


@st.composite
def fitting_images(draw: st.DrawFn) -> tuple[str, int, int, int, bytes]:
    """Fields that hold together (any fields rarely do): a taken encoding, a small size, a
    step of a row or a little more, and the bytes that fills, or one short of it."""
    encoding = draw(st.sampled_from(["rgb8", "bgr8", "mono8"]))
    width, height = draw(st.integers(1, 12)), draw(st.integers(1, 12))
    step = width * (1 if encoding == "mono8" else 3) + draw(st.integers(0, 3))
    size = step * height - draw(st.sampled_from([0, 0, 0, 1]))
    return encoding, width, height, step, draw(st.binary(min_size=size, max_size=size))


def test_image_fields_give_pixels_or_one_line() -> None:
    target = "sensor.ros2_images.raw_image"

    @FUZZ
    @given(
        st.one_of(
            st.tuples(encodings, sides, sides, sides, st.binary(max_size=600)), fitting_images()
        )
    )
    def case(fields: tuple[str, int, int, int, bytes]) -> None:
        encoding, width, height, step, data = fields
        pixels = outcome(
            target,
            lambda: raw_image(encoding, width, height, step, data),
            (UnsupportedImage, BadImage),
        )
        if pixels is not None:
            assert pixels.shape == (height, width, 3) and pixels.dtype == np.uint8

    case()
    check_tally(target, "valid", "refused")


def test_compressed_images_give_a_jpeg_or_one_line() -> None:
    target = "sensor.ros2_images.compressed_image"
    payloads = st.one_of(
        st.just(JPEG),
        st.integers(0, len(JPEG)).map(lambda n: JPEG[:n]),
        damaged(JPEG),
        st.binary(max_size=300),
    )

    @FUZZ
    @given(st.text(max_size=40), payloads)
    def case(image_format: str, data: bytes) -> None:
        image = outcome(
            target, lambda: compressed_image(image_format, data), (UnsupportedImage, BadImage)
        )
        if image is not None:
            assert (image.width, image.height) == jpeg_size(image.data)

    case()
    check_tally(target, "valid", "refused")
