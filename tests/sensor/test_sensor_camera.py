"""``--camera``: a device index, a /dev/video* path or a stream URL, with our own errors; the
simulated head's MJPEG URL through the real camera source."""

from __future__ import annotations

import asyncio
import socket
from pathlib import Path

import msgspec
import pytest

from facesynth.app.simhead import SimHead, load_head
from facesynth.app.simhead.maestro import Maestro
from facesynth.app.simhead.server import SimHeadServer
from facesynth.services.sensor.sources.base import SourceError, pixels
from facesynth.services.sensor.sources.camera import CameraConfig, CameraSource, camera_target


@pytest.mark.parametrize(
    ("value", "target"),
    [
        (0, 0),
        (3, 3),
        ("2", 2),
        (" 1 ", 1),
        ("/dev/null", "/dev/null"),  # a character device, as /dev/video* are
        ("http://127.0.0.1:8090/camera.mjpg", "http://127.0.0.1:8090/camera.mjpg"),
        ("rtsp://cam.local:554/stream1", "rtsp://cam.local:554/stream1"),
        ("HTTPS://phone:8080/video", "HTTPS://phone:8080/video"),
    ],
)
def test_what_a_camera_can_be(value: int | str, target: int | str) -> None:
    assert camera_target(value) == target


@pytest.mark.parametrize(
    ("value", "message"),
    [
        (-1, "--camera -1: a device index is 0 or more"),
        ("-2", "--camera -2: a device index is 0 or more"),
        ("front", "--camera 'front': expected a device index (0), a /dev/video* path"),
        ("", "--camera '': expected"),
        ("/dev/video-none", "--camera /dev/video-none: no such device"),
        ("/tmp", "--camera /tmp: not a camera device"),
        ("ftp://host/cam", "cannot stream ftp:// (known: http://"),
        ("http://", "the URL has no host"),
        ("http:///camera.mjpg", "the URL has no host"),
    ],
)
def test_what_a_camera_cannot_be(value: int | str, message: str) -> None:
    with pytest.raises(SourceError) as info:
        camera_target(value)
    assert message in str(info.value)


def test_a_file_is_not_a_camera(tmp_path: Path) -> None:
    video = tmp_path / "clip.mp4"
    video.write_bytes(b"x")
    with pytest.raises(SourceError, match="a file, not a camera \\(use --video for files\\)"):
        camera_target(str(video))


def test_the_flag_reaches_the_config_as_text() -> None:
    """The command line gives strings; a graph file may give an int."""
    for given, kept in (("0", "0"), (0, 0), ("/dev/video0", "/dev/video0")):
        config = msgspec.convert({"source": "camera", "index": given}, CameraConfig, strict=False)
        assert config.index == kept
    with pytest.raises(msgspec.ValidationError, match=">= 0"):
        msgspec.convert({"source": "camera", "index": -1}, CameraConfig)


def test_nothing_streaming_is_one_clear_error() -> None:
    with socket.socket() as probe:  # a port nobody listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    url = f"http://127.0.0.1:{port}/camera.mjpg"
    with pytest.raises(SourceError, match=f"cannot open the camera stream {url}"):
        CameraSource(CameraConfig(index=url))


def _read(url: str, count: int) -> list[tuple[tuple[int, ...], int]]:
    source = CameraSource(CameraConfig(index=url))
    try:
        assert source.info.live and source.info.name == f"camera:{url}"
        assert source.info.frames is None and 0 < source.info.fps <= 1000
        out = []
        for image, t_ns in source.frames():
            assert image is not None
            out.append((pixels(image).shape, t_ns))
            if len(out) == count:
                return out
        raise AssertionError("the stream ended")
    finally:
        source.close()


async def test_the_simulated_heads_camera_url(tmp_path: Path) -> None:
    server = SimHeadServer(SimHead(load_head("simhead16")), Maestro(), tmp_path / "tty", fps=30)
    await server.start()
    try:
        frames = await asyncio.to_thread(_read, server.url, 5)
    finally:
        await server.stop()
    assert [shape for shape, _ in frames] == [(320, 320, 3)] * 5
    times = [t for _, t in frames]
    assert times == sorted(times)
