"""facesynth.runtime.frames (pixels in and out of Frame messages) and services.sensor.sources."""

from __future__ import annotations

import itertools
import re
from importlib import resources
from pathlib import Path

import cv2
import numpy as np
import pytest

from facesynth.runtime import codec
from facesynth.runtime.frames import FrameError, decode_frame, encode_frame
from facesynth.schemas.messages import Frame
from facesynth.services.sensor.sources import SourceError
from facesynth.services.sensor.sources.folder import FolderConfig, FolderSource
from facesynth.services.sensor.sources.ticks import TicksConfig, TickSource
from facesynth.services.sensor.sources.video import VideoConfig, VideoSource

VIDEO = Path(str(resources.files("facesynth.app.data") / "WolfgangLanger_Pexels.mp4"))


def _image(height: int = 48, width: int = 64, seed: int = 0) -> np.ndarray:
    """A smooth BGR gradient plus a little noise: JPEG keeps it close."""
    y, x = np.mgrid[0:height, 0:width]
    image = np.stack([x * 255 // width, y * 255 // height, (x + y) * 127 // (width + height)], -1)
    noise = np.random.default_rng(seed).integers(0, 4, image.shape)
    return (image + noise).astype(np.uint8)


def _encode(image: np.ndarray, encoding: str = "jpeg", **kw) -> Frame:  # type: ignore[no-untyped-def]
    return encode_frame(image, seq=3, t_capture_ns=11, t_media_ns=22, encoding=encoding, **kw)


# --- encode / decode --------------------------------------------------------------------------


def test_raw_round_trip_is_exact() -> None:
    image = _image(30, 40)
    frame = _encode(image, "raw", source="cam", fps=25.0)
    assert (frame.width, frame.height, frame.encoding) == (40, 30, "raw")
    assert len(frame.data) == 30 * 40 * 3
    assert (frame.seq, frame.t_capture_ns, frame.t_media_ns, frame.source, frame.fps) == (
        3,
        11,
        22,
        "cam",
        25.0,
    )
    decoded = decode_frame(codec.decode(codec.encode(frame), Frame))
    np.testing.assert_array_equal(decoded, image)


def test_raw_accepts_a_non_contiguous_view() -> None:
    image = _image(30, 40)[:, ::2]  # every other column: not contiguous
    frame = _encode(image, "raw")
    np.testing.assert_array_equal(decode_frame(frame), image)


def test_jpeg_round_trip_is_close() -> None:
    image = _image()
    frame = _encode(image, "jpeg", quality=95)
    assert frame.data[:2] == b"\xff\xd8"
    assert (frame.width, frame.height) == (64, 48)
    decoded = decode_frame(codec.decode(codec.encode(frame), Frame))
    assert decoded.shape == image.shape and decoded.dtype == np.uint8
    assert np.abs(decoded.astype(int) - image.astype(int)).mean() < 3


def test_jpeg_quality_is_used() -> None:
    noisy = np.random.default_rng(1).integers(0, 256, (64, 64, 3), dtype=np.uint8)
    small = _encode(noisy, quality=10).data
    large = _encode(noisy, quality=95).data
    assert len(small) < len(large) / 2


@pytest.mark.parametrize(
    ("image", "detail"),
    [
        (np.zeros((4, 4), np.uint8), "(4, 4) uint8"),
        (np.zeros((4, 4, 4), np.uint8), "(4, 4, 4) uint8"),
        (np.zeros((4, 4, 3), np.float32), "(4, 4, 3) float32"),
        (np.zeros((4, 4, 3), np.uint16), "(4, 4, 3) uint16"),
    ],
    ids=["gray", "bgra", "float", "uint16"],
)
def test_encode_refuses_non_bgr_images(image: np.ndarray, detail: str) -> None:
    with pytest.raises(FrameError, match="need an HxWx3 uint8 BGR image") as info:
        _encode(image)
    assert detail in str(info.value)


def test_encode_refuses_unknown_encoding() -> None:
    with pytest.raises(FrameError, match="unknown frame encoding 'png' \\(use jpeg or raw\\)"):
        _encode(_image(), "png")


def _frame(encoding: str, data: bytes, width: int = 64, height: int = 48) -> Frame:
    return Frame(
        seq=9,
        t_capture_ns=1,
        t_media_ns=2,
        width=width,
        height=height,
        encoding=encoding,
        data=data,
    )  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("frame", "detail"),
    [
        (_frame("raw", bytes(64 * 48 * 3 - 1)), "raw frame needs 9216 bytes, got 9215"),
        (_frame("raw", bytes(64 * 48 * 3), width=65), "raw frame needs 9360 bytes, got 9216"),
        (_frame("jpeg", b"\xff\xd8" + b"\x00" * 100), "frame 9: JPEG data cannot be decoded"),
        (_frame("jpeg", b""), "frame 9: JPEG data cannot be decoded"),
        (_frame("jpeg", _encode(_image()).data[:200]), "frame 9: JPEG data cannot be decoded"),
        (
            _frame("jpeg", _encode(_image()).data, width=32),
            "frame 9: JPEG is 64x48, header says 32x48",
        ),
        (
            _frame("jpeg", _encode(_image()).data, height=49),
            "frame 9: JPEG is 64x48, header says 64x49",
        ),
        (_frame("none", b""), "frame 9 has no pixels (encoding 'none')"),
    ],
    ids=[
        "raw-short",
        "raw-wrong-width",
        "jpeg-garbage",
        "jpeg-empty",
        "jpeg-truncated",
        "jpeg-wrong-width",
        "jpeg-wrong-height",
        "tick",
    ],
)
def test_decode_errors(frame: Frame, detail: str) -> None:
    with pytest.raises(FrameError) as info:
        decode_frame(frame)
    assert str(info.value) == detail


# --- VideoSource ------------------------------------------------------------------------------


def test_video_source_reads_the_sample_video() -> None:
    source = VideoSource(VideoConfig(path=str(VIDEO)))
    try:
        assert source.info.fps == pytest.approx(23.98, abs=0.01)
        assert source.info.frames == 472
        assert source.info.live is False
        frames = list(itertools.islice(source.frames(), 3))
    finally:
        source.close()
    assert [image.shape for image, _ in frames] == [(360, 640, 3)] * 3
    period = 1e9 / source.info.fps
    assert [t for _, t in frames] == [0, round(period), round(2 * period)]
    assert not np.array_equal(frames[0][0], frames[2][0])  # real, moving frames


def test_a_small_video_decodes_on_one_thread_and_a_large_one_on_ffmpegs_default(
    tmp_path: Path,
) -> None:
    large = tmp_path / "large.mp4"
    writer = cv2.VideoWriter(str(large), cv2.VideoWriter_fourcc(*"mp4v"), 30.0, (1920, 1080))
    for value in (0, 128):
        writer.write(np.full((1080, 1920, 3), value, np.uint8))
    writer.release()
    threads = {}
    for name, path in (("small", VIDEO), ("large", large)):
        source = VideoSource(VideoConfig(path=str(path)))
        try:
            threads[name] = source._capture.get(cv2.CAP_PROP_N_THREADS)
            assert next(iter(source.frames()))[0] is not None
        finally:
            source.close()
    assert threads["small"] == 1 and threads["large"] != 1, threads


def test_video_source_fps_override() -> None:
    source = VideoSource(VideoConfig(path=str(VIDEO), fps=10.0))
    try:
        times = [t for _, t in itertools.islice(source.frames(), 3)]
    finally:
        source.close()
    assert source.info.fps == 10.0
    assert times == [0, 100_000_000, 200_000_000]


def test_video_source_errors(tmp_path: Path) -> None:
    missing = tmp_path / "gone.mp4"
    with pytest.raises(SourceError, match=f"video {re.escape(str(missing))} does not exist"):
        VideoSource(VideoConfig(path=str(missing)))
    garbage = tmp_path / "garbage.mp4"
    garbage.write_bytes(b"this is not a video" * 200)
    with pytest.raises(SourceError, match=f"cannot open {re.escape(str(garbage))} as a video"):
        VideoSource(VideoConfig(path=str(garbage)))
    with pytest.raises(SourceError, match="does not exist"):
        VideoSource(VideoConfig(path=str(tmp_path)))  # a folder is not a video file


# --- FolderSource -----------------------------------------------------------------------------


def _folder(tmp_path: Path, names: list[str]) -> Path:
    folder = tmp_path / "images"
    folder.mkdir()
    for index, name in enumerate(names):
        image = np.full((20, 30, 3), index * 40, np.uint8)
        assert cv2.imwrite(str(folder / name), image)
    return folder


def test_folder_source_reads_images_in_name_order(tmp_path: Path) -> None:
    folder = _folder(tmp_path, ["b.png", "a.png", "c.bmp"])
    (folder / "notes.txt").write_text("not an image")
    source = FolderSource(FolderConfig(folder=str(folder), fps=10.0))
    assert source.info.frames == 3
    assert [p.name for p in source.files] == ["a.png", "b.png", "c.bmp"]
    frames = list(source.frames())
    # a.png was written second (value 40), b.png first (0), c.bmp third (80).
    assert [int(image[0, 0, 0]) for image, _ in frames] == [40, 0, 80]
    assert [t for _, t in frames] == [0, 100_000_000, 200_000_000]


def test_folder_source_loops_with_growing_media_time(tmp_path: Path) -> None:
    source = FolderSource(
        FolderConfig(folder=str(_folder(tmp_path, ["a.png", "b.png"])), fps=4.0, loop=True)
    )
    frames = list(itertools.islice(source.frames(), 5))
    assert [int(image[0, 0, 0]) for image, _ in frames] == [0, 40, 0, 40, 0]
    assert [t for _, t in frames] == [0, 250_000_000, 500_000_000, 750_000_000, 1_000_000_000]


def test_folder_source_errors(tmp_path: Path) -> None:
    with pytest.raises(SourceError, match=r"image folder .*gone does not exist"):
        FolderSource(FolderConfig(folder=str(tmp_path / "gone")))
    empty = tmp_path / "empty"
    empty.mkdir()
    (empty / "readme.md").write_text("x")
    where = re.escape(str(empty))
    with pytest.raises(SourceError, match=f"no images \\(.png, .jpg.*\\) in {where}"):
        FolderSource(FolderConfig(folder=str(empty)))
    folder = _folder(tmp_path, ["a.png"])
    for fps in (0.0, -1.0, float("nan")):
        with pytest.raises(SourceError, match="the image folder rate must be positive"):
            FolderSource(FolderConfig(folder=str(folder), fps=fps))


def test_folder_source_garbage_image(tmp_path: Path) -> None:
    folder = _folder(tmp_path, ["a.png"])
    (folder / "b.jpg").write_bytes(b"not a jpeg at all")
    source = FolderSource(FolderConfig(folder=str(folder)))
    frames = source.frames()
    first, _ = next(frames)
    assert first.shape == (20, 30, 3)
    with pytest.raises(SourceError, match=r"b\.jpg is not a readable image"):
        next(frames)


# --- TickSource -------------------------------------------------------------------------------


def test_tick_source() -> None:
    source = TickSource(TicksConfig(count=4, fps=20.0))
    assert (source.info.name, source.info.fps, source.info.frames) == ("ticks", 20.0, 4)
    assert list(source.frames()) == [
        (None, 0),
        (None, 50_000_000),
        (None, 100_000_000),
        (None, 150_000_000),
    ]


def test_tick_source_rounds_media_time() -> None:
    times = [t for _, t in TickSource(TicksConfig(count=4, fps=30.0)).frames()]
    assert times == [0, 33_333_333, 66_666_667, 100_000_000]


@pytest.mark.parametrize(
    ("count", "fps"),
    [(0, 30.0), (-1, 30.0), (5, 0.0), (5, -30.0), (5, float("nan"))],
    ids=["zero-count", "negative-count", "zero-fps", "negative-fps", "nan-fps"],
)
def test_tick_source_errors(count: int, fps: float) -> None:
    with pytest.raises(SourceError, match="ticks need a positive count and rate"):
        TickSource(TicksConfig(count=count, fps=fps))
