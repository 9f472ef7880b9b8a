"""MJPEG passthrough: a camera URL's JPEG parts reach ``…/input`` byte for byte, from the
simulated head's real server and from small aiohttp servers that misbehave (a part that is not
a JPEG, a JPEG cut short, a wrong boundary, a server that stops, an answer that is not MJPEG);
and the choice between passthrough and decoding (URL, device buffers)."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator, Awaitable, Callable, Iterator
from pathlib import Path

import numpy as np
import pytest
from aiohttp import web

from facesynth.app.simhead import SimHead, load_head
from facesynth.app.simhead.maestro import Maestro
from facesynth.app.simhead.server import SimHeadServer
from facesynth.runtime.frames import decode_frame
from facesynth.runtime.opencv import import_cv2
from facesynth.runtime.testing import StageRun
from facesynth.services.points.backends.tracker import TrackerBackend, TrackerConfig
from facesynth.services.sensor.service import SensorOptions, SensorService
from facesynth.services.sensor.sources import FrameSource, JpegImage, SourceError, SourceInfo
from facesynth.services.sensor.sources.base import Image, pixels
from facesynth.services.sensor.sources.camera import (
    MJPG_FOURCC,
    CameraConfig,
    CameraSource,
    capture_mode,
    device_frame,
)

cv2 = import_cv2(RuntimeError)


def jpeg(shade: int, size: tuple[int, int] = (64, 48)) -> bytes:
    width, height = size
    image = np.full((height, width, 3), shade, np.uint8)
    image[:, : width // 2, 2] = 255 - shade
    ok, data = cv2.imencode(".jpg", image)
    assert ok
    return bytes(data.tobytes())


JPEGS = [jpeg(shade) for shade in (10, 80, 150, 220)]


def undecodable(data: bytes) -> bytes:
    """A JPEG with a sound header whose components name an undefined quantisation table."""
    out = bytearray(data)
    sof = out.find(b"\xff\xc0")
    for component in range(out[sof + 9]):
        out[sof + 10 + 3 * component + 2] = 3
    return bytes(out)


class RecordingServer(SimHeadServer):
    """The simulated head's server, keeping every JPEG it renders."""

    rendered: list[bytes]

    def _render(self) -> None:
        super()._render()
        if not hasattr(self, "rendered"):
            self.rendered = []
        self.rendered.append(self._frame)


def read(url: str, count: int, **config: object) -> tuple[list[Image], CameraSource]:
    source = CameraSource(CameraConfig(index=url, **config))  # type: ignore[arg-type]
    out: list[Image] = []
    try:
        for image, _ in source.frames():
            out.append(image)
            if len(out) == count:
                break
    finally:
        source.close()
    return out, source


async def test_the_simulated_heads_jpegs_arrive_byte_for_byte(tmp_path: Path) -> None:
    server = RecordingServer(SimHead(load_head("simhead16")), Maestro(), tmp_path / "tty", fps=30)
    await server.start()
    try:
        images, source = await asyncio.to_thread(read, server.url, 5)
    finally:
        await server.stop()
    assert source.mode == "mjpeg-url" and source.parts_dropped == 0
    assert all(isinstance(image, JpegImage) for image in images)
    jpegs = [image for image in images if isinstance(image, JpegImage)]
    assert {(j.width, j.height) for j in jpegs} == {(320, 320)}
    assert all(j.data in server.rendered for j in jpegs)
    assert pixels(jpegs[0]).shape == (320, 320, 3)


async def test_the_points_stage_tracks_the_passed_through_frames(tmp_path: Path) -> None:
    server = SimHeadServer(SimHead(load_head("simhead16")), Maestro(), tmp_path / "tty", fps=30)
    await server.start()
    try:
        images, _ = await asyncio.to_thread(read, server.url, 3)
    finally:
        await server.stop()
    run = sensor_run([image for image in images if isinstance(image, JpegImage)], "jpeg")
    async with run:
        await run.finish(timeout=10.0)
        frames = run.messages("input")
    backend = TrackerBackend(TrackerConfig(model="full", blendshapes=False))
    points = [backend.process(frame) for frame in frames]
    assert [p.face for p in points] == [True] * 3
    assert {(p.image_width, p.image_height) for p in points} == {(320, 320)}


async def test_no_passthrough_decodes_as_before(tmp_path: Path) -> None:
    server = SimHeadServer(SimHead(load_head("simhead16")), Maestro(), tmp_path / "tty", fps=30)
    await server.start()
    try:
        images, source = await asyncio.to_thread(read, server.url, 2, passthrough=False)
    finally:
        await server.stop()
    assert source.mode == "decode"
    assert [getattr(image, "shape", None) for image in images] == [(320, 320, 3)] * 2


# --- misbehaving servers -------------------------------------------------------------------------

Handler = Callable[[web.Request], Awaitable[web.StreamResponse]]
STOP = web.AppKey("stop", asyncio.Event)


@contextlib.asynccontextmanager
async def serving(handler: Handler) -> AsyncIterator[str]:
    app = web.Application()
    app[STOP] = asyncio.Event()
    app.router.add_get("/cam.mjpg", handler)
    runner = web.AppRunner(app)
    await runner.setup()
    site = web.TCPSite(runner, "127.0.0.1", 0)
    await site.start()
    port = runner.addresses[0][1]
    try:
        yield f"http://127.0.0.1:{port}/cam.mjpg"
    finally:
        app[STOP].set()
        await runner.cleanup()


def streaming(
    parts: list[bytes], *, boundary: str = "frame", declared: str | None = None, hold: bool = True
) -> Handler:
    """Serve ``parts`` (raw bytes of each part, already framed), then hold or close."""

    async def handler(request: web.Request) -> web.StreamResponse:
        response = web.StreamResponse(
            headers={"Content-Type": f"multipart/x-mixed-replace; boundary={declared or boundary}"}
        )
        await response.prepare(request)
        for part in parts:
            await response.write(part)
        if hold:  # until the test's server stops
            await request.app[STOP].wait()
        return response

    return handler


def part(body: bytes, *, boundary: str = "frame", length: int | None = None) -> bytes:
    size = len(body) if length is None else length
    head = f"--{boundary}\r\nContent-Type: image/jpeg\r\nContent-Length: {size}\r\n\r\n"
    return head.encode() + body + b"\r\n"


async def test_every_part_as_served() -> None:
    async with serving(streaming([part(j) for j in JPEGS])) as url:
        images, _ = await asyncio.to_thread(read, url, len(JPEGS))
    assert [getattr(i, "data", None) for i in images] == JPEGS


async def test_parts_without_content_length_end_at_the_boundary() -> None:
    body = b"".join(b"--frame\r\nContent-Type: image/jpeg\r\n\r\n" + j + b"\r\n" for j in JPEGS)
    # Without a length, a part ends when the next boundary line comes.
    async with serving(streaming([body + b"--frame\r\n"])) as url:
        images, _ = await asyncio.to_thread(read, url, len(JPEGS))
    assert [getattr(i, "data", None) for i in images] == JPEGS


async def test_parts_that_are_not_jpegs_are_dropped_and_counted(
    caplog: pytest.LogCaptureFixture,
) -> None:
    cut_short = JPEGS[1][: len(JPEGS[1]) // 2]  # a JPEG without its end
    parts = [part(JPEGS[0]), part(b"<html>oops</html>"), part(cut_short), part(JPEGS[2])]
    async with serving(streaming(parts)) as url:
        images, source = await asyncio.to_thread(read, url, 2)
    assert [getattr(i, "data", None) for i in images] == [JPEGS[0], JPEGS[2]]
    assert source.parts_dropped == 2
    assert "dropped a part that is not a JPEG (not a JPEG (no start-of-image marker)" in caplog.text


async def test_a_wrong_boundary_is_one_clear_error() -> None:
    async with serving(streaming([part(JPEGS[0], boundary="other")])) as url:
        with pytest.raises(
            SourceError, match="not an MJPEG stream: expected the boundary '--frame'"
        ):
            await asyncio.to_thread(read, url, 1)


async def test_a_server_that_stops_mid_part_is_a_stopped_camera() -> None:
    truncated = part(JPEGS[0])[:-200]  # Content-Length promises more than comes
    async with serving(streaming([part(JPEGS[1]), truncated], hold=False)) as url:
        with pytest.raises(SourceError, match="the camera stopped delivering frames"):
            await asyncio.to_thread(read, url, 3)


async def test_a_closing_boundary_ends_the_camera() -> None:
    async with serving(streaming([part(JPEGS[0]), b"--frame--\r\n"])) as url:
        with pytest.raises(SourceError, match="stopped delivering frames \\(stream ended\\)"):
            await asyncio.to_thread(read, url, 3)


async def test_no_boundary_parameter_is_one_clear_error() -> None:
    async def handler(request: web.Request) -> web.Response:
        return web.Response(body=b"x", headers={"Content-Type": "multipart/x-mixed-replace"})

    async with serving(handler) as url:
        with pytest.raises(SourceError, match=r"not an MJPEG stream: .* names no usable boundary"):
            await asyncio.to_thread(read, url, 1)


async def test_an_http_error_is_one_clear_error() -> None:
    async def handler(request: web.Request) -> web.Response:
        raise web.HTTPNotFound()

    async with serving(handler) as url:
        with pytest.raises(SourceError, match=r"cannot open the camera stream .* \(HTTP 404"):
            await asyncio.to_thread(read, url, 1)


async def test_an_answer_that_is_not_mjpeg_goes_to_ffmpeg() -> None:
    async def handler(request: web.Request) -> web.Response:
        return web.Response(text="<html>a camera page</html>", content_type="text/html")

    async with serving(handler) as url:
        with pytest.raises(SourceError, match=f"cannot open the camera stream {url}"):
            await asyncio.to_thread(read, url, 1)


async def test_a_silent_server_times_out(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr("facesynth.services.sensor.sources.camera.STREAM_TIMEOUT_MS", 500)
    async with serving(streaming([])) as url:
        with pytest.raises(SourceError, match="stopped delivering frames \\(timed out\\)"):
            await asyncio.to_thread(read, url, 1)


# --- the choice ----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("target", "options", "mode"),
    [
        ("http://cam/video.mjpg", {}, "mjpeg-url"),
        ("HTTPS://cam/video.mjpg", {}, "mjpeg-url"),
        ("http://cam/video.mjpg", {"width": 640, "height": 480}, "decode"),
        ("http://cam/video.mjpg", {"passthrough": False}, "decode"),
        ("rtsp://cam/stream1", {}, "decode"),
        (0, {}, "device-mjpg"),
        ("/dev/video2", {"width": 1280, "height": 720}, "device-mjpg"),
        (0, {"passthrough": False}, "decode"),
    ],
)
def test_when_frames_pass_through(target: int | str, options: dict[str, object], mode: str) -> None:
    settings: dict[str, object] = {"passthrough": True, "width": 0, "height": 0} | options
    assert capture_mode(target, **settings) == mode  # type: ignore[arg-type]


def test_a_devices_buffer() -> None:
    flat = np.frombuffer(JPEGS[0], np.uint8)
    assert device_frame(flat) == JpegImage(JPEGS[0], 64, 48)
    assert device_frame(flat.reshape(1, -1)) == JpegImage(JPEGS[0], 64, 48)
    pixels_in = np.zeros((48, 64, 3), np.uint8)  # the back end decoded anyway
    assert device_frame(pixels_in) is pixels_in
    yuyv = np.zeros((48, 64, 2), np.uint8)
    for unusable in (None, np.zeros(0, np.uint8), yuyv, np.frombuffer(b"\x00" * 64, np.uint8)):
        assert device_frame(unusable) is None
    assert device_frame(np.frombuffer(JPEGS[0][:-300], np.uint8)) is None  # cut short
    assert cv2.VideoWriter_fourcc(*"MJPG") == MJPG_FOURCC


# --- on the bus ----------------------------------------------------------------------------------


class Jpegs(FrameSource):
    def __init__(self, images: list[JpegImage]) -> None:
        self.images = images
        self.info = SourceInfo("camera:test", 30.0, None, live=True)

    def frames(self) -> Iterator[tuple[Image, int]]:
        for index, image in enumerate(self.images):
            yield image, index * 33_000_000


def sensor_run(images: list[JpegImage], encoding: str) -> StageRun:
    sensor = SensorService(Jpegs(images), SensorOptions(encoding=encoding))
    return StageRun(sensor.serve, service="sensor")


@pytest.mark.parametrize("encoding", ["jpeg", "raw", "auto"])
async def test_frames_on_the_bus_decode_downstream(encoding: str) -> None:
    good = [JpegImage(data, 64, 48) for data in JPEGS]
    broken = JpegImage(undecodable(JPEGS[0]), 64, 48)
    run = sensor_run([good[0], broken, *good[1:]], encoding)
    async with run:
        await run.finish(timeout=10.0)
        frames = run.messages("input")
    if encoding != "raw":  # as they are (auto too): the points stage finds the broken one
        assert [f.data for f in frames] == [JPEGS[0], broken.data, *JPEGS[1:]]
        frames = [frames[0], *frames[2:]]
    else:  # decoded here: the broken one is dropped and counted
        assert [f.seq for f in frames] == [0, 2, 3, 4]
    sent = "raw" if encoding == "raw" else "jpeg"
    assert {(f.encoding, f.width, f.height) for f in frames} == {(sent, 64, 48)}
    for frame, data in zip(frames, JPEGS, strict=True):
        expected = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
        assert np.array_equal(decode_frame(frame), expected)
