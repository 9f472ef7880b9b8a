"""The sensor's ``auto`` encoding (a graph's default): the stages of the sensor's own process
take its raw pixels, with no JPEG encoded for them; a subscriber in another session (a real
router on loopback) and a recorder get the same frame as JPEG at the sensor's quality, encoded
once a frame, and only while someone wants bytes. ``jpeg`` and ``raw`` give every reader the
same frames, as before."""

from __future__ import annotations

import asyncio
from collections.abc import Iterator

import cv2
import numpy as np
import pytest

from facesynth.runtime import codec
from facesynth.runtime.bus import zenoh_outlet
from facesynth.runtime.bus.base import Bus, Subscription
from facesynth.runtime.bus.memory import MemoryBus
from facesynth.runtime.bus.zenoh_bus import ZenohBus, ZenohOptions
from facesynth.runtime.frames import decode_frame
from facesynth.runtime.service import ServiceContext
from facesynth.schemas.messages import Frame
from facesynth.services.sensor.service import SensorOptions, SensorService
from facesynth.services.sensor.sources import FrameSource, SourceInfo
from facesynth.services.sensor.sources.base import Image

FRAMES = 6
QUALITY = 80
TIMEOUT = 10.0


def picture(seq: int) -> np.ndarray:
    """A 64x48 BGR picture of its own for each frame (a gradient shifted by ``seq``)."""
    y, x = np.mgrid[0:48, 0:64]
    return np.stack([(x * 4 + seq * 9) % 256, y * 5, (x + y + seq) % 256], -1).astype(np.uint8)


class Pictures(FrameSource):
    """A live source of :data:`FRAMES` pictures (live: sent at once, without pacing)."""

    def __init__(self) -> None:
        self.info = SourceInfo("pictures", 30.0, None, live=True)

    def frames(self) -> Iterator[tuple[Image, int]]:
        for seq in range(FRAMES):
            yield picture(seq), seq * 33_000_000


class JpegCount:
    """Counts OpenCV's JPEG encodes (every JPEG the sensor makes), calling the real one."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        self.count = 0
        real = cv2.imencode

        def counted(ext: str, image: np.ndarray, params: list[int]) -> tuple[bool, np.ndarray]:
            if ext == ".jpg":
                self.count += 1
            return real(ext, image, params)

        monkeypatch.setattr(cv2, "imencode", counted)


def expected_jpeg(seq: int) -> bytes:
    ok, buffer = cv2.imencode(".jpg", picture(seq), [cv2.IMWRITE_JPEG_QUALITY, QUALITY])
    assert ok
    return buffer.tobytes()


async def play(bus: Bus, rig: str, encoding: str) -> tuple[Subscription, Subscription]:
    """The sensor's frames on ``bus``, beside P's own mailbox (taking objects, as P's service
    subscribes) and a recorder's (bytes); returns those two once every frame was sent."""
    points = ServiceContext(bus, rig, "points").subscribe("input", 64, Frame)
    recorder = ServiceContext(bus, rig, "recorder").subscribe("input", 64)
    sensor = SensorService(Pictures(), SensorOptions(encoding=encoding, quality=QUALITY))
    assert await sensor.serve(ServiceContext(bus, rig, "sensor")) == FRAMES - 1
    await asyncio.sleep(0)  # the last samples reach the mailboxes
    return points, recorder


def received(subscription: Subscription) -> list[Frame]:
    frames = []
    while (sample := subscription.receive_nowait()) is not None:
        frames.append(sample.message or codec.decode(sample.payload, Frame))
    return frames


def client(router: str) -> ZenohBus:
    return ZenohBus.open(ZenohOptions(mode="client", connect=[router]))


def check_raw(frames: list[Frame]) -> None:
    assert [f.seq for f in frames] == list(range(FRAMES))
    assert {f.encoding for f in frames} == {"raw"}
    for frame in frames:
        assert np.array_equal(decode_frame(frame), picture(frame.seq))


async def test_in_process_p_takes_raw_pixels_and_nothing_is_encoded_without_a_reader_of_bytes(
    zenoh_router: str, rig: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    # No subscriber elsewhere, none of bytes here: after the new publisher's grace (shortened),
    # not one JPEG is made.
    monkeypatch.setattr(zenoh_outlet, "MATCH_GRACE_S", 0.0)
    jpegs = JpegCount(monkeypatch)
    bus = client(zenoh_router)
    try:
        points = ServiceContext(bus, rig, "points").subscribe("input", 64, Frame)
        sensor = SensorService(Pictures(), SensorOptions(encoding="auto", quality=QUALITY))
        await sensor.serve(ServiceContext(bus, rig, "sensor"))
        await asyncio.sleep(0)
        check_raw(received(points))
        assert jpegs.count == 0
    finally:
        await bus.close()


async def test_a_subscriber_elsewhere_and_a_recorder_get_jpeg_encoded_once_a_frame(
    zenoh_router: str, rig: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    sender, observer = client(zenoh_router), client(zenoh_router)
    try:
        remote = observer.subscribe_queued(f"facesynth/{rig}/input", 64)
        await asyncio.sleep(0.5)  # the subscriber is known to the router
        jpegs = JpegCount(monkeypatch)
        points, recorder = await play(sender, rig, "auto")
        check_raw(received(points))
        recorded = received(recorder)
        elsewhere: list[Frame] = []
        while len(elsewhere) < FRAMES:
            sample = await asyncio.wait_for(remote.receive(), TIMEOUT)
            elsewhere.append(codec.decode(sample.payload, Frame))  # checked as P would
        assert jpegs.count == FRAMES  # once a frame, for the recorder and the session alike
        for frames in (recorded, elsewhere):
            assert [f.seq for f in frames] == list(range(FRAMES))
            assert {(f.encoding, f.width, f.height) for f in frames} == {("jpeg", 64, 48)}
            assert [f.data for f in frames] == [expected_jpeg(seq) for seq in range(FRAMES)]
    finally:
        await sender.close()
        await observer.close()


@pytest.mark.parametrize(("encoding", "everywhere"), [("jpeg", "jpeg"), ("raw", "raw")])
async def test_jpeg_and_raw_give_every_reader_the_same_frames(
    encoding: str, everywhere: str, rig: str
) -> None:
    points, recorder = await play(MemoryBus(), rig, encoding)
    taken, recorded = received(points), received(recorder)
    assert taken == recorded
    assert {f.encoding for f in taken} == {everywhere}
    if encoding == "jpeg":  # byte for byte what a five-process chain's P gets
        assert [f.data for f in taken] == [expected_jpeg(seq) for seq in range(FRAMES)]


async def test_a_raw_frame_in_process_is_still_checked(rig: str) -> None:
    # P's mailbox checks an object as it checks decoded bytes: a raw frame whose pixels are not
    # its header's size is refused there, counted.
    bus = MemoryBus()
    points = ServiceContext(bus, rig, "points").subscribe("input", 4, Frame)
    sensor = ServiceContext(bus, rig, "sensor")
    for seq, size in enumerate((23, 24, 25)):
        frame = Frame(
            seq=seq,
            t_capture_ns=1,
            t_media_ns=0,
            width=4,
            height=2,
            encoding="raw",
            data=bytes(size),
        )
        sensor.publish("input", frame)
    await asyncio.sleep(0)
    assert [f.seq for f in received(points)] == [1]
    assert points.refused == 2
