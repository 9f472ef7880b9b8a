"""The simulated head as a device: a Maestro on a pseudo-terminal and an MJPEG camera.

The thin asyncio shell around the pure cores: :class:`~.maestro.Maestro` answers the bytes a
servo driver writes to the pty behind ``link`` (a symlink the user names, e.g.
``/tmp/simhead-tty``, pointing at the pty's ``/dev/pts/N``), its output pulses drive the
:class:`~.head.SimHead`, whose dynamics step every :data:`DYNAMICS_S` on the monotonic clock,
and its rendering, with a little camera grain (``noise``, grey levels; the tracker then
jitters as on a real camera), is served at ``fps`` by aiohttp:

* ``/camera.mjpg``: ``multipart/x-mixed-replace`` JPEG frames (what OpenCV, browsers and IP
  camera viewers open);
* ``/camera.jpg``: the latest frame;
* ``/``: a page showing the stream.

A learner only ever sees these two things, never the head's file.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import time
import tty
from collections.abc import Callable
from pathlib import Path
from typing import Final

import cv2
import numpy as np
from aiohttp import web

from facesynth.runtime.tasks import stop_tasks
from facesynth.runtime.web_app import serve_app

from .head import SimHead
from .maestro import Maestro

__all__ = ["DYNAMICS_S", "PtyPort", "SimHeadServer", "SimHeadServerError"]

#: How often the Maestro's ramps and the head's actuators are stepped.
DYNAMICS_S: Final = 0.005
BOUNDARY: Final = "simheadframe"
PAGE: Final = (
    "<!doctype html><title>facesynth simhead</title>"
    '<body style="margin:0;background:#111"><img src="camera.mjpg" alt="camera"></body>'
)


def _noise_bank(sigma: float, shape: tuple[int, ...], frames: int = 8) -> list[np.ndarray]:
    """A few frames of camera grain (Gaussian, ``sigma`` grey levels; none for 0)."""
    if sigma <= 0:
        return []
    rng = np.random.default_rng(0)
    return [rng.normal(0.0, sigma, shape).astype(np.float32) for _ in range(frames)]


class SimHeadServerError(ValueError):
    """The simulated head cannot serve as asked (a link path, an address)."""


def point_link(link: Path, target: str) -> None:
    """Make ``link`` a symlink to ``target`` atomically (a reader never sees it missing)."""
    tmp = link.with_name(link.name + ".new")
    with contextlib.suppress(FileNotFoundError):
        tmp.unlink()
    tmp.symlink_to(target)
    os.replace(tmp, link)


class PtyPort:
    """A pseudo-terminal whose other end a driver opens through the symlink ``link``.

    ``on_bytes`` gets every chunk the driver writes and returns the answer to write back. We
    keep the pty's slave open too, so a driver may close and reopen the port.
    """

    def __init__(self, link: Path, on_bytes: Callable[[bytes], bytes]) -> None:
        if link.exists() and not link.is_symlink():
            raise SimHeadServerError(f"{link} exists and is not a symlink: not replacing it")
        if not link.parent.is_dir():
            raise SimHeadServerError(f"{link.parent} is not a folder")
        self.link = link
        self.on_bytes = on_bytes
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)  # no echo, no line editing: bytes pass as they are
        os.set_blocking(self._master, False)
        self.device = os.ttyname(self._slave)
        try:
            point_link(link, self.device)
        except OSError as exc:
            for fd in (self._master, self._slave):
                os.close(fd)
            raise SimHeadServerError(f"cannot make the link {link} ({exc.strerror})") from None
        self._loop: asyncio.AbstractEventLoop | None = None

    def attach(self, loop: asyncio.AbstractEventLoop) -> None:
        """Start answering on ``loop``."""
        self._loop = loop
        loop.add_reader(self._master, self._readable)

    def _readable(self) -> None:
        try:
            data = os.read(self._master, 4096)
        except OSError:  # nothing to read yet, or no reader on the driver's side right now
            return
        if data:
            self.write(self.on_bytes(data))

    def write(self, data: bytes) -> None:
        """Send bytes to the driver (dropped if its side does not read: a full pty)."""
        view = memoryview(data)
        deadline = time.monotonic() + 0.5
        while view and time.monotonic() < deadline:
            try:
                view = view[os.write(self._master, view) :]
            except BlockingIOError:
                time.sleep(0.001)

    def close(self) -> None:
        """Stop answering, remove the link (if still ours) and close the pty."""
        if self._loop is not None:
            self._loop.remove_reader(self._master)
            self._loop = None
        with contextlib.suppress(OSError):
            if os.readlink(self.link) == self.device:
                self.link.unlink()
        for fd in (self._master, self._slave):
            with contextlib.suppress(OSError):
                os.close(fd)


class SimHeadServer:
    """The head's serial port and camera (see the module doc).

    ``clock`` gives monotonic nanoseconds (tests may pass their own).
    """

    def __init__(
        self,
        head: SimHead,
        maestro: Maestro,
        link: Path,
        host: str = "127.0.0.1",
        port: int = 0,
        fps: float = 30.0,
        quality: int = 85,
        noise: float = 1.5,
        clock: Callable[[], int] = time.monotonic_ns,
    ) -> None:
        if not 0 < fps <= 120:
            raise SimHeadServerError(f"--fps {fps:g} is not within (0, 120]")
        if not 0 <= noise <= 20:
            raise SimHeadServerError(f"--noise {noise:g} is not within [0, 20]")
        self.head = head
        self.maestro = maestro
        self.link = link
        self.host = host
        self.port = port
        self.fps = fps
        self.quality = quality
        self._noise_sigma = noise
        self._noise: list[np.ndarray] = []
        self._clock = clock
        self._t0 = clock()
        self._port: PtyPort | None = None
        self._runner: web.AppRunner | None = None
        self._tasks: list[asyncio.Task[None]] = []
        self._frame = b""
        self._frame_seq = 0
        self._new_frame = asyncio.Event()
        self.frames_served = 0
        self._closing = False

    @property
    def url(self) -> str:
        """The camera's MJPEG URL."""
        return f"http://{self.host}:{self.port}/camera.mjpg"

    @property
    def snapshot_url(self) -> str:
        """The latest frame's URL."""
        return f"http://{self.host}:{self.port}/camera.jpg"

    @property
    def device(self) -> str:
        """The pty the link points at."""
        assert self._port is not None
        return self._port.device

    def _now(self) -> int:
        return self._clock() - self._t0

    def _advance(self) -> None:
        """Step the Maestro's ramps and the head's actuators to now."""
        now = self._now()
        if now < self.head.t_ns:
            return
        self.maestro.step(now)
        for channel, pulse in self.maestro.outputs().items():
            self.head.command(channel, pulse)
        self.head.step(now)

    def _serial(self, data: bytes) -> bytes:
        self._advance()
        answer = self.maestro.feed(data)
        self._advance()
        return answer

    async def start(self) -> None:
        """Open the serial port and listen (``SimHeadServerError`` if the address is taken)."""
        self._port = PtyPort(self.link, self._serial)
        self._port.attach(asyncio.get_running_loop())
        self._render()
        app = web.Application()
        app.router.add_get("/", self._page)
        app.router.add_get("/camera.mjpg", self._mjpeg)
        app.router.add_get("/camera.jpg", self._snapshot)
        try:
            self._runner, self.port = await serve_app(app, self.host, self.port)
        except OSError as exc:
            await self.stop()
            raise SimHeadServerError(
                f"cannot listen on {self.host}:{self.port} ({exc.strerror})"
            ) from None
        self._tasks.append(asyncio.create_task(self._dynamics(), name="simhead-dynamics"))
        self._tasks.append(asyncio.create_task(self._camera(), name="simhead-camera"))

    async def stop(self) -> None:
        """Stop serving, then the camera and the dynamics; close the port, remove the link."""
        self._closing = True
        self._new_frame.set()  # wake every stream: they end
        if self._runner is not None:
            await self._runner.cleanup()
            self._runner = None
        try:
            await stop_tasks(self._tasks)
        finally:  # the port closed even when this stop is cancelled
            self._tasks.clear()
            if self._port is not None:
                self._port.close()
                self._port = None

    async def _dynamics(self) -> None:
        while True:
            self._advance()
            await asyncio.sleep(DYNAMICS_S)

    def _render(self) -> None:
        image = self.head.render()
        if self._noise_sigma and not self._noise:
            self._noise = _noise_bank(self._noise_sigma, image.shape)
        if self._noise:
            grain = self._noise[self._frame_seq % len(self._noise)]
            image = np.clip(image + grain, 0, 255).astype(np.uint8)
        ok, jpeg = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, self.quality])
        if ok:
            self._frame = jpeg.tobytes()
            self._frame_seq += 1
            self._new_frame.set()
            self._new_frame = asyncio.Event()

    async def _camera(self) -> None:
        period = 1.0 / self.fps
        loop = asyncio.get_running_loop()
        next_at = loop.time()
        while True:
            self._advance()
            self._render()
            next_at += period
            delay = next_at - loop.time()
            if delay < -period:  # fell behind: start again from now
                next_at, delay = loop.time(), 0.0
            await asyncio.sleep(max(0.0, delay))

    async def _page(self, request: web.Request) -> web.Response:
        return web.Response(text=PAGE, content_type="text/html")

    async def _snapshot(self, request: web.Request) -> web.Response:
        return web.Response(body=self._frame, content_type="image/jpeg")

    async def _mjpeg(self, request: web.Request) -> web.StreamResponse:
        response = web.StreamResponse(
            headers={
                "Content-Type": f"multipart/x-mixed-replace; boundary={BOUNDARY}",
                "Cache-Control": "no-cache, no-store",
                "Connection": "close",
            }
        )
        await response.prepare(request)
        seq = -1
        with contextlib.suppress(ConnectionError, asyncio.CancelledError):
            while not self._closing:
                if seq == self._frame_seq:
                    await self._new_frame.wait()
                    continue
                seq, frame = self._frame_seq, self._frame
                part = (
                    f"--{BOUNDARY}\r\nContent-Type: image/jpeg\r\n"
                    f"Content-Length: {len(frame)}\r\n\r\n"
                ).encode()
                await response.write(part + frame + b"\r\n")
                self.frames_served += 1
        return response
