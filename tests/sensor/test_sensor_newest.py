"""services.sensor.sources.newest and ``--newest-frame``: a live stream read in a thread, only its
newest frame passed on, stamped when it arrived; frames a slow taker missed are dropped and
counted; the stream's end and errors reach the taker; closing the camera ends the thread. The
camera cases run a real aiohttp MJPEG server that sends faster than the test takes."""

from __future__ import annotations

import asyncio
import contextlib
import queue
import threading
import time
from collections.abc import AsyncIterator, Iterator

import numpy as np
import pytest
from aiohttp import web

from facesynth.runtime.opencv import import_cv2
from facesynth.services.sensor.sources import JpegImage, SourceError
from facesynth.services.sensor.sources.camera import CameraConfig, CameraSource
from facesynth.services.sensor.sources.newest import NewestFrame

cv2 = import_cv2(RuntimeError)
END = object()


def fed(items: queue.Queue[object]) -> Iterator[int]:
    """What the test puts on ``items``, until END (or an exception, raised)."""
    while (item := items.get(timeout=10)) is not END:
        if isinstance(item, BaseException):
            raise item
        assert isinstance(item, int)
        yield item


def counter(start: int = 0) -> Iterator[int]:
    value = start
    while True:
        yield value
        value += 1


def test_only_the_newest_frame_is_taken_and_the_others_are_counted() -> None:
    items: queue.Queue[object] = queue.Queue()
    stamps = counter(1000)
    newest = NewestFrame(fed(items), wall=lambda: next(stamps), monotonic=lambda: 7)
    for frame in (1, 2, 3):
        items.put(frame)
    items.put(END)
    assert newest.join(5.0)
    taken = newest.take()
    assert taken is not None
    assert (taken.frame, taken.wall_ns, taken.monotonic_ns) == (3, 1002, 7)
    assert newest.dropped == 2
    assert newest.take() is None  # the stream ended: nothing newer comes


def test_each_frame_is_taken_once_and_the_taker_waits_for_a_newer_one() -> None:
    items: queue.Queue[object] = queue.Queue()
    newest = NewestFrame(fed(items))
    items.put(1)
    first = newest.take()
    assert first is not None and first.frame == 1
    later: list[int] = []
    taker = threading.Thread(target=lambda: later.append(getattr(newest.take(), "frame", -1)))
    taker.start()
    time.sleep(0.2)
    assert not later  # no frame newer than the one taken yet: it waits
    items.put(2)
    taker.join(5.0)
    assert later == [2]
    items.put(END)
    assert list(newest) == []
    assert newest.dropped == 0


def test_the_streams_error_comes_after_its_last_frame() -> None:
    items: queue.Queue[object] = queue.Queue()
    newest = NewestFrame(fed(items))
    items.put(5)
    items.put(SourceError("camera:x: the camera stopped delivering frames"))
    assert newest.join(5.0)
    taken = newest.take()
    assert taken is not None and taken.frame == 5
    with pytest.raises(SourceError, match="stopped delivering frames"):
        newest.take()


# --- a camera URL that sends faster than it is taken ----------------------------------------------


def numbered(index: int) -> bytes:
    """A small JPEG whose comment segment carries ``index``."""
    ok, data = cv2.imencode(".jpg", np.full((16, 16, 3), index % 255, np.uint8))
    assert ok
    jpeg = bytes(data.tobytes())
    comment = f"frame {index:06d}".encode()
    segment = b"\xff\xfe" + (len(comment) + 2).to_bytes(2, "big") + comment
    return jpeg[:2] + segment + jpeg[2:]


def index_of(image: object) -> int:
    assert isinstance(image, JpegImage)
    start = image.data.index(b"frame ") + len(b"frame ")
    return int(image.data[start : start + 6])


@contextlib.asynccontextmanager
async def fast_camera(period_s: float) -> AsyncIterator[str]:
    """An MJPEG URL sending a numbered frame every ``period_s``, each as soon as it can."""
    stop = asyncio.Event()

    async def handler(request: web.Request) -> web.StreamResponse:
        response = web.StreamResponse(
            headers={"Content-Type": "multipart/x-mixed-replace; boundary=frame"}
        )
        await response.prepare(request)
        with contextlib.suppress(ConnectionError):
            for index in range(100_000):
                if stop.is_set():
                    break
                body = numbered(index)
                head = f"--frame\r\nContent-Type: image/jpeg\r\nContent-Length: {len(body)}\r\n\r\n"
                await response.write(head.encode() + body + b"\r\n")
                with contextlib.suppress(TimeoutError):  # woken at once when the camera stops
                    await asyncio.wait_for(stop.wait(), period_s)
        return response

    app = web.Application()
    app.router.add_get("/cam.mjpg", handler)
    runner = web.AppRunner(app)
    await runner.setup()
    site = web.TCPSite(runner, "127.0.0.1", 0)
    await site.start()
    try:
        yield f"http://127.0.0.1:{runner.addresses[0][1]}/cam.mjpg"
    finally:
        stop.set()
        await runner.cleanup()


def take_slowly(url: str, newest: bool) -> tuple[list[int], list[int | None], list[int], int]:
    """Two frames, 0.3 s apart: their indexes, capture times, when each was taken, drops."""
    source = CameraSource(CameraConfig(index=url, newest=newest))
    indexes: list[int] = []
    captured: list[int | None] = []
    taken: list[int] = []
    try:
        frames = source.frames()
        for _ in range(2):
            image, _ = next(frames)
            taken.append(time.time_ns())
            indexes.append(index_of(image))
            captured.append(source.capture_time_ns())
            time.sleep(0.3)
    finally:
        source.close()
    return indexes, captured, taken, source.stale_dropped


async def test_a_slow_taker_gets_the_newest_frame_stamped_when_it_arrived() -> None:
    async with fast_camera(0.005) as url:
        indexes, captured, taken, dropped = await asyncio.to_thread(take_slowly, url, True)
    assert indexes[1] - indexes[0] >= 10  # 0.3 s of frames every 5 ms went by meanwhile
    assert dropped >= 10
    first, second = captured
    assert first is not None and second is not None
    assert taken[0] < second <= taken[1]  # it arrived while the taker slept, not when taken


async def test_without_newest_frame_every_frame_comes_in_order() -> None:
    async with fast_camera(0.005) as url:
        indexes, captured, _, dropped = await asyncio.to_thread(take_slowly, url, False)
    assert indexes[1] == indexes[0] + 1  # the one queued behind it: 0.3 s old by now
    assert captured == [None, None] and dropped == 0  # the sensor stamps it when it takes it


async def test_closing_the_camera_ends_its_reading_thread() -> None:
    async with fast_camera(3600.0) as url:  # one frame, then silence

        def open_take_close() -> bool:
            source = CameraSource(CameraConfig(index=url, newest=True))
            next(source.frames())
            source.close()
            assert source._newest is not None
            return source._newest.join(2.0)

        assert await asyncio.to_thread(open_take_close)
