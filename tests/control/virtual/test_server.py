"""The virtual driver's page server over real sockets: pages, WebSockets, the rig's data."""

from __future__ import annotations

import asyncio
import json
import sys
import time

import aiohttp
import numpy as np
import pytest

from facesynth.runtime import codec, keys
from facesynth.runtime.bus.memory import MemoryBus
from facesynth.runtime.frames import encode_frame
from facesynth.runtime.plugins import PluginError
from facesynth.runtime.profiles import load_profile
from facesynth.schemas.messages import Points, PointSet, ServiceStats
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.base import DriverError
from facesynth.services.control.drivers.virtual import (
    AddressError,
    VirtualConfig,
    VirtualDriver,
    parse_address,
    wire,
)
from facesynth.services.control.drivers.virtual.geometry import face_geometry
from tests.control.virtual.conftest import open_page, start_driver

JAW_OPEN = {"jaw": 1000.0, "lower_lip": 600.0}


async def test_the_page_and_its_files_are_served(page_driver: VirtualDriver) -> None:
    async with aiohttp.ClientSession() as session:
        for path, kind, needle in (
            ("", "text/html", "face.js"),
            ("face.js", "text/javascript", "pageLink(state"),
            ("link.js", "text/javascript", "new WebSocket"),
            ("frames.js", "text/javascript", "createImageBitmap"),
            ("bars.js", "text/javascript", "function servoBar"),
            ("stages.js", "text/javascript", "function showStages"),
            ("face.css", "text/css", "canvas"),
        ):
            async with session.get(page_driver.url + path) as response:
                assert response.status == 200
                assert response.content_type == kind
                assert needle in await response.text()
        async with session.get(page_driver.url + "favicon.ico") as response:
            assert response.status == 204
        for path in ("nope", "../../etc/passwd", "static/face.js"):
            async with session.get(page_driver.url + path) as response:
                assert response.status == 404
        async with session.get(page_driver.url + "state") as response:
            state = await response.json()
        assert state["clients"] == 0 and state["refused"] == 0


async def test_a_page_gets_hello_then_each_command_with_its_face(
    page_driver: VirtualDriver,
) -> None:
    async with aiohttp.ClientSession() as session:
        page = await open_page(session, page_driver)
        hello = await page.next("hello")
        assert hello["profile"] == "virtual" and hello["face"] is True
        assert [c["name"] for c in hello["controls"]][:2] == ["brow_right", "brow_left"]
        positions = {**load_profile("virtual").neutral_positions(), **JAW_OPEN}
        await page_driver.send(positions, CommandInfo(7, 123, True))
        face = await page.next("face")
        assert (face["seq"], face["face"], face["t_capture_ns"]) == (7, True, 123)
        expected = json.loads(wire.face(7, True, positions, face_geometry(positions), 123))
        assert face["shapes"] == expected["shapes"]
        await page.ws.close()


async def test_a_page_that_opens_late_sees_the_current_face(page_driver: VirtualDriver) -> None:
    await page_driver.send(JAW_OPEN, CommandInfo(3, None, True))
    async with aiohttp.ClientSession() as session:
        page = await open_page(session, page_driver)
        assert (await page.next("face"))["seq"] == 3


async def test_a_profile_that_is_not_a_face_gets_bars_only() -> None:
    driver = await start_driver("paper16")
    try:
        async with aiohttp.ClientSession() as session:
            page = await open_page(session, driver)
            hello = await page.next("hello")
            assert hello["face"] is False and len(hello["controls"]) == 16
            await driver.send({"jaw": 1800.0}, CommandInfo(1, None, True))
            face = await page.next("face")
            assert face["shapes"] is None and face["controls"] == {"jaw": 1800.0}
    finally:
        await driver.close()


@pytest.mark.parametrize(
    ("send", "code"),
    [
        ("text:not json", aiohttp.WSCloseCode.POLICY_VIOLATION),
        ('text:{"type": "move", "jaw": 1000}', aiohttp.WSCloseCode.POLICY_VIOLATION),
        ("binary:\x00\x01", aiohttp.WSCloseCode.UNSUPPORTED_DATA),
        ("text:" + "x" * 5000, aiohttp.WSCloseCode.MESSAGE_TOO_BIG),
        ("binary:" + "y" * 100_000, aiohttp.WSCloseCode.MESSAGE_TOO_BIG),
    ],
    ids=["not-json", "unknown-type", "binary", "oversized-text", "oversized-binary"],
)
async def test_malformed_or_oversized_messages_close_only_that_page(
    page_driver: VirtualDriver, send: str, code: int
) -> None:
    async with aiohttp.ClientSession() as session:
        good = await open_page(session, page_driver)
        bad = await open_page(session, page_driver)
        await bad.next("hello")
        kind, payload = send.split(":", 1)
        if kind == "text":
            await bad.ws.send_str(payload)
        else:
            await bad.ws.send_bytes(payload.encode())
        closed = await bad.ws.receive(timeout=5)
        assert closed.type == aiohttp.WSMsgType.CLOSE and closed.data == code
        await page_driver.send(JAW_OPEN, CommandInfo(9, None, True))
        assert (await good.next("face"))["seq"] == 9  # the other page goes on
        assert page_driver.server is not None and page_driver.server.refused == 1
        again = await open_page(session, page_driver)  # and new pages are welcome
        assert (await again.next("face"))["seq"] == 9


async def test_ping_is_answered(page_driver: VirtualDriver) -> None:
    async with aiohttp.ClientSession() as session:
        page = await open_page(session, page_driver)
        await page.ws.send_str('{"type": "ping", "t": 41.5}')
        assert (await page.next("pong"))["t"] == 41.5


async def test_another_sites_page_is_refused(page_driver: VirtualDriver) -> None:
    async with aiohttp.ClientSession() as session:
        with pytest.raises(aiohttp.WSServerHandshakeError) as info:
            await session.ws_connect(
                page_driver.url + "ws", headers={"Origin": "http://evil.example"}
            )
        assert info.value.status == 403
        host = page_driver.url.split("//")[1].rstrip("/")
        page = await open_page(session, page_driver, headers={"Origin": f"http://{host}"})
        assert (await page.next("hello"))["profile"] == "virtual"


async def test_pages_beyond_max_clients_are_turned_away() -> None:
    driver = await start_driver(max_clients=2)
    try:
        async with aiohttp.ClientSession() as session:
            pages = [await open_page(session, driver) for _ in range(2)]
            for page in pages:
                await page.next("hello")
            with pytest.raises(aiohttp.WSServerHandshakeError) as info:
                await session.ws_connect(driver.url + "ws")
            assert info.value.status == 503
            await pages[0].ws.close()
            await asyncio.sleep(0.05)
            await (await open_page(session, driver)).next("hello")
    finally:
        await driver.close()


async def test_several_pages_all_get_the_newest_face(page_driver: VirtualDriver) -> None:
    async with aiohttp.ClientSession() as session:
        pages = [await open_page(session, page_driver) for _ in range(5)]
        for seq in range(30):
            await page_driver.send({"jaw": seq * 30.0}, CommandInfo(seq, None, True))
        for page in pages:
            seen = -1
            while seen < 29:
                seen = (await page.next("face"))["seq"]
        assert page_driver.server is not None
        assert page_driver.server.state()["clients"] == 5


async def test_a_stalled_page_never_slows_the_driver(page_driver: VirtualDriver) -> None:
    """A page that stops reading fills its socket, then only its own mailbox: the driver's send
    stays a dictionary store per page, and the other pages get every newest face."""
    assert page_driver.server is not None
    async with aiohttp.ClientSession() as session:
        stalled = await session.ws_connect(page_driver.url + "ws")  # never read from here on
        reader = await open_page(session, page_driver)
        big = {name: 500.0 for name in load_profile("virtual").neutral_positions()}
        timings = []
        for seq in range(600):
            t0 = time.perf_counter()
            await page_driver.send({**big, "jaw": float(seq % 1000)}, CommandInfo(seq, None, True))
            timings.append(time.perf_counter() - t0)
            if seq % 50 == 0:
                await asyncio.sleep(0)  # let the writers run, as the control loop would
            if seq % 100 == 0:
                page_driver.server.fanout.offer("frame", b"\x00" * 300_000)  # fill the socket
        seen = -1
        while seen < 599:
            seen = (await reader.next("face"))["seq"]
        dropped = page_driver.server.state()["dropped"]
        assert dropped > 0  # the stalled page lost older faces, nobody waited for it
        # Every send is computed once and stored per page; none waits on a socket.
        assert sorted(timings)[len(timings) // 2] < 0.01
        await stalled.close()


async def test_the_page_follows_the_rigs_frames_points_and_stats() -> None:
    bus, rig = MemoryBus(), "cam"
    driver = await start_driver(bus=bus, rig=rig)
    try:
        input_key = keys.stage_key(rig, "input")
        assert driver.server is not None
        assert not driver.server.state()["follows_frames"]  # nobody watches: no frames pulled
        async with aiohttp.ClientSession() as session:
            page = await open_page(session, driver)
            await page.next("hello")
            image = np.full((36, 64, 3), 200, np.uint8)
            frame = encode_frame(image, seq=4, t_capture_ns=1, t_media_ns=1)
            points = Points(
                seq=4,
                t_capture_ns=1,
                t_media_ns=1,
                face=True,
                image_width=64,
                image_height=36,
                sets=[PointSet(scheme="ibug68", dims=2, coords=[1.0] * 136)],
            )
            stats = ServiceStats(
                service="points",
                instance="h-1",
                rig=rig,
                t_ns=1,
                uptime_s=1.0,
                received=1,
                published=1,
                dropped=0,
                rejected=0,
                rate_hz=30.0,
                latency_p50_ms=4.0,
            )
            for _ in range(50):  # until the page's subscriptions are there
                if driver.server.state()["follows_frames"]:
                    break
                await asyncio.sleep(0.02)
            bus.publish(input_key, b"garbage")  # counted, never forwarded
            for _ in range(100):
                if driver.server.state()["rejected_input"] == 1:
                    break
                await asyncio.sleep(0.02)
            assert driver.server.state()["rejected_input"] == 1
            bus.publish(input_key, codec.encode(frame))
            bus.publish(keys.stage_key(rig, "points"), codec.encode(points))
            bus.publish(keys.stats_key(rig, "points", "h-1"), codec.encode(stats))
            got = await page.collect({"frame", "points", "stats"})
            header, jpeg = wire.read_frame(got["frame"])
            assert header == {"seq": 4, "width": 64, "height": 36, "encoding": "jpeg"}
            assert jpeg == frame.data
            assert got["points"]["ibug68"] == [1.0] * 136
            rows = got["stats"]["services"]
            assert rows[0]["service"] == "points" and rows[0]["p50_ms"] == 4.0
            await page.ws.send_str('{"type": "hello", "frames": false}')
            for _ in range(100):  # the last page stopped watching: the input is let go
                if not driver.server.state()["follows_frames"]:
                    break
                await asyncio.sleep(0.02)
            assert not driver.server.state()["follows_frames"]
            await asyncio.sleep(0.7)
            assert not any(str(key_expr) == input_key for key_expr, _ in bus.network.subscriptions)
    finally:
        await driver.close()


def test_http_addresses() -> None:
    assert parse_address("127.0.0.1:8080") == ("127.0.0.1", 8080)
    assert parse_address("[::1]:0") == ("::1", 0)
    assert parse_address("0.0.0.0:80") == ("0.0.0.0", 80)
    for bad in ("8080", "host", ":8080", "host:", "host:99999", "host:80a", "host:-1", "host:²"):
        with pytest.raises(AddressError, match="--http: expected HOST:PORT"):
            parse_address(bad)


async def test_a_taken_port_is_a_driver_error(page_driver: VirtualDriver) -> None:
    taken = page_driver.url.split("//")[1].rstrip("/")
    other = VirtualDriver(VirtualConfig(http=taken), load_profile("virtual"))
    with pytest.raises(DriverError, match=f"cannot serve the live face page on {taken}"):
        await other.connect()
    with pytest.raises(DriverError, match="not connected"):
        await other.send({}, CommandInfo(None, None, False))


def test_without_aiohttp_the_error_names_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "aiohttp", None)
    with pytest.raises(PluginError, match=r"pip install 'facesynth\[face\]'"):
        VirtualDriver(VirtualConfig(), load_profile("virtual"))
