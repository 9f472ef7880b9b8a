"""The tracker's frame decoding (:mod:`facesynth.services.points.tracker.jpeg_rgba`): a JPEG
decoded straight to RGBA gives exactly the pixels of OpenCV's BGR decode converted to RGBA,
on the bundled video and on JPEGs of every kind OpenCV writes, and OpenCV still decides the
JPEGs it treats differently (EXIF orientation, cut short, corrupt, CMYK).
"""

from __future__ import annotations

import struct

import numpy as np
import pytest
from tracker_fixtures import VIDEO

import facesynth.services.points.tracker.jpeg_rgba as jpeg_rgba
from facesynth.runtime.frames import FrameError, decode_frame, encode_frame
from facesynth.runtime.opencv import import_cv2
from facesynth.schemas.messages import Frame
from facesynth.services.points.tracker.jpeg_rgba import decode_rgba
from facesynth.services.points.tracker.model_input import frame_to_rgba
from facesynth.services.points.tracker.offline import iter_video_frames

cv2 = import_cv2(RuntimeError)


def jpeg_frame(data: bytes, width: int, height: int, seq: int = 7) -> Frame:
    return Frame(
        seq=seq,
        t_capture_ns=0,
        t_media_ns=0,
        width=width,
        height=height,
        encoding="jpeg",
        data=data,
    )


def opencv_rgba(frame: Frame) -> np.ndarray:
    """What the tracker decoded before: OpenCV's BGR, converted to RGBA."""
    return frame_to_rgba(decode_frame(frame))


@pytest.fixture()
def without_opencv_decode(monkeypatch: pytest.MonkeyPatch) -> None:
    """OpenCV's decode made unusable: a decode that works took simplejpeg's path."""

    def refuse(frame: Frame) -> np.ndarray:
        raise AssertionError("OpenCV decoded a frame simplejpeg should have")

    monkeypatch.setattr(jpeg_rgba, "decode_frame", refuse)


def textured(height: int, width: int, seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    smooth = cv2.resize(rng.integers(0, 256, (8, 8, 3), dtype=np.uint8), (width, height))
    noise = rng.integers(0, 40, (height, width, 3), dtype=np.uint8)
    return cv2.add(smooth, noise)


def test_the_bundled_video_decodes_to_the_same_pixels_frame_by_frame() -> None:
    """Every third frame of the bundled video as the sensor sends it (JPEG, quality 90)."""
    out = None
    compared = 0
    for index, image in enumerate(iter_video_frames(VIDEO)):
        if index % 3:
            continue
        frame = encode_frame(image, seq=index, t_capture_ns=0, t_media_ns=0)
        expected = opencv_rgba(frame)
        out = decode_rgba(frame, out)
        assert out.dtype == np.uint8 and out.shape == expected.shape
        assert np.array_equal(out, expected), f"frame {index} differs"
        compared += 1
    assert compared > 100


@pytest.mark.parametrize(
    "params",
    [
        [cv2.IMWRITE_JPEG_QUALITY, 90],
        [cv2.IMWRITE_JPEG_QUALITY, 40],
        [cv2.IMWRITE_JPEG_QUALITY, 100],
        [cv2.IMWRITE_JPEG_SAMPLING_FACTOR, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_411],
        [cv2.IMWRITE_JPEG_SAMPLING_FACTOR, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_422],
        [cv2.IMWRITE_JPEG_SAMPLING_FACTOR, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_440],
        [cv2.IMWRITE_JPEG_SAMPLING_FACTOR, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_444],
        [cv2.IMWRITE_JPEG_PROGRESSIVE, 1],
        [cv2.IMWRITE_JPEG_OPTIMIZE, 1],
        [cv2.IMWRITE_JPEG_RST_INTERVAL, 4],
    ],
    ids=["q90", "q40", "q100", "411", "422", "440", "444", "progressive", "optimized", "restart"],
)
@pytest.mark.parametrize("size", [(37, 63), (240, 320), (481, 641)], ids=str)
def test_jpegs_of_every_kind_decode_to_the_same_pixels(
    params: list[int], size: tuple[int, int], without_opencv_decode: None
) -> None:
    image = textured(*size)
    data = cv2.imencode(".jpg", image, params)[1].tobytes()
    frame = jpeg_frame(data, size[1], size[0])
    got = decode_rgba(frame)
    assert np.array_equal(got, opencv_rgba(frame))


def test_a_grey_jpeg_decodes_to_the_same_pixels(without_opencv_decode: None) -> None:
    grey = textured(50, 70)[:, :, 0].copy()
    frame = jpeg_frame(cv2.imencode(".jpg", grey)[1].tobytes(), 70, 50)
    got = decode_rgba(frame)
    assert np.array_equal(got, opencv_rgba(frame))
    assert np.array_equal(got[:, :, 0], got[:, :, 2]) and (got[:, :, 3] == 255).all()


def with_exif_orientation(data: bytes, orientation: int) -> bytes:
    """``data`` with an APP1 EXIF block holding an orientation tag, after its SOI marker."""
    tiff = b"II*\x00" + struct.pack("<I", 8) + struct.pack("<H", 1)
    tiff += struct.pack("<HHII", 0x0112, 3, 1, orientation) + struct.pack("<I", 0)
    body = b"Exif\x00\x00" + tiff
    return data[:2] + b"\xff\xe1" + struct.pack(">H", len(body) + 2) + body + data[2:]


def test_a_jpeg_with_an_exif_orientation_is_decoded_by_opencv_as_before() -> None:
    """Turned upside down (orientation 3), as OpenCV reads it; libjpeg-turbo alone would not."""
    image = textured(40, 60)
    plain = cv2.imencode(".jpg", image)[1].tobytes()
    frame = jpeg_frame(with_exif_orientation(plain, 3), 60, 40)
    expected = opencv_rgba(frame)
    unturned = opencv_rgba(jpeg_frame(plain, 60, 40))
    assert np.array_equal(expected, unturned[::-1, ::-1])  # OpenCV did turn it
    assert np.array_equal(decode_rgba(frame), expected)


def test_a_jpeg_cut_short_gives_what_opencv_gives() -> None:
    data = cv2.imencode(".jpg", textured(120, 160))[1].tobytes()
    frame = jpeg_frame(data[: len(data) * 2 // 3], 160, 120)
    try:
        expected = opencv_rgba(frame)
    except FrameError as exc:
        with pytest.raises(FrameError, match="cannot be decoded"):
            decode_rgba(frame)
        assert "cannot be decoded" in str(exc)
    else:
        assert np.array_equal(decode_rgba(frame), expected)


@pytest.mark.parametrize(
    "data",
    [b"", b"\xff\xd8", b"\xff\xd8\xff\xdb\x00\x04\x00\x00", b"not a jpeg at all" * 10],
    ids=["empty", "soi-only", "broken-table", "text"],
)
def test_bytes_that_are_no_jpeg_are_refused_in_one_line(data: bytes) -> None:
    with pytest.raises(FrameError, match=r"^frame 7: JPEG data cannot be decoded$"):
        decode_rgba(jpeg_frame(data, 16, 8))


def test_a_jpeg_of_another_size_than_its_frame_says_is_refused() -> None:
    data = cv2.imencode(".jpg", textured(30, 40))[1].tobytes()
    with pytest.raises(FrameError, match=r"^frame 7: JPEG is 40x30, header says 40x20$"):
        decode_rgba(jpeg_frame(data, 40, 20))
    with pytest.raises(FrameError, match=r"^frame 7: JPEG is 40x30, header says 50x30$"):
        decode_rgba(jpeg_frame(data, 50, 30))


def test_the_buffer_is_reused_when_it_fits_and_left_alone_when_not() -> None:
    image = textured(30, 40)
    frame = jpeg_frame(cv2.imencode(".jpg", image)[1].tobytes(), 40, 30)
    buffer = np.zeros((30, 40, 4), np.uint8)
    got = decode_rgba(frame, buffer)
    assert np.shares_memory(got, buffer) and np.array_equal(buffer, opencv_rgba(frame))
    wrong = np.zeros((31, 40, 4), np.uint8)
    got = decode_rgba(frame, wrong)
    assert not np.shares_memory(got, wrong) and not wrong.any()
    assert np.array_equal(got, opencv_rgba(frame))


def test_a_raw_frame_and_a_host_without_simplejpeg_decode_as_before(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    image = textured(30, 40)
    raw = encode_frame(image, seq=1, t_capture_ns=0, t_media_ns=0, encoding="raw")
    assert np.array_equal(decode_rgba(raw), cv2.cvtColor(image, cv2.COLOR_BGR2RGBA))
    frame = encode_frame(image, seq=2, t_capture_ns=0, t_media_ns=0)
    monkeypatch.setattr(jpeg_rgba, "simplejpeg", None)
    assert np.array_equal(decode_rgba(frame), opencv_rgba(frame))


def test_a_tick_frame_without_pixels_is_refused() -> None:
    tick = Frame(seq=3, t_capture_ns=0, t_media_ns=0, width=640, height=480, encoding="none")
    with pytest.raises(FrameError, match="has no pixels"):
        decode_rgba(tick)


def test_the_tracker_backend_gives_the_points_it_gave_from_opencvs_pixels() -> None:
    """P's backend (decoding to RGBA) against the same backend decoding as it did before
    (OpenCV's BGR, then converted): the same Points, byte for byte, over 60 frames."""
    import msgspec

    from facesynth.services.points.backends.tracker import TrackerBackend

    backend, before = TrackerBackend(), TrackerBackend()
    before._decode_rgba = lambda frame, out: frame_to_rgba(decode_frame(frame), out)
    faces = 0
    for index, image in enumerate(iter_video_frames(VIDEO)):
        if index == 60:
            break
        frame = encode_frame(image, seq=index, t_capture_ns=0, t_media_ns=0)
        got, expected = backend.process(frame), before.process(frame)
        assert msgspec.msgpack.encode(got) == msgspec.msgpack.encode(expected), index
        faces += got.face
    assert faces > 50


@pytest.mark.parametrize(
    "image",
    [np.zeros((4, 4, 3), np.uint8), np.zeros((4, 4, 4), np.float32), np.zeros((0, 4, 4), np.uint8)],
    ids=["bgr", "float", "empty"],
)
def test_the_tracker_takes_only_rgba_frames_through_process_rgba(image: np.ndarray) -> None:
    from facesynth.services.points.tracker import FaceTracker

    with pytest.raises(ValueError, match=r"expected a uint8 \(H, W, 4\) RGBA image"):
        FaceTracker().process_rgba(image)
