"""The live face page in a real headless Chromium: it loads, connects, draws the face the
commands describe, shows the rig's frames and landmarks, refuses bad messages, and comes back
when the service restarts."""

from __future__ import annotations

import asyncio
import json
import socket
import time
from typing import Any

import aiohttp
import msgspec
import numpy as np
import pytest

from facesynth.runtime import codec, keys
from facesynth.runtime.bus.memory import MemoryBus
from facesynth.runtime.frames import encode_frame
from facesynth.runtime.profiles import load_profile
from facesynth.schemas.messages import Points, PointSet, ServiceStats
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.virtual import VirtualDriver
from facesynth.services.control.drivers.virtual.geometry import MOUTH, face_geometry
from tests.browser.conftest import js, wait_js
from tests.control.virtual.conftest import open_page, start_driver

pytestmark = pytest.mark.browser

NEUTRAL = load_profile("virtual").neutral_positions()
OPEN = {**NEUTRAL, "jaw": 1000.0, "lower_lip": 1000.0}

PIXEL = (
    "Array.from(document.getElementById(arguments[0]).getContext('2d')"
    ".getImageData(arguments[1], arguments[2], 1, 1).data.slice(0, 3))"
)
CANVAS_SUM = (
    "(() => { const d = document.getElementById('face').getContext('2d')"
    ".getImageData(0, 0, 400, 480).data; let s = 0;"
    " for (let i = 0; i < d.length; i += 7) s = (s * 31 + d[i]) % 1000000007; return s; })()"
)


def _rgb(colour: str) -> list[int]:
    return [int(colour[i : i + 2], 16) for i in (1, 3, 5)]


def _mouth_centre(positions: dict[str, float]) -> tuple[int, int]:
    mouth = next(s for s in face_geometry(positions) if s.name == "mouth")
    xs, ys = zip(*mouth.points, strict=True)
    return round(sum(xs) / len(xs)), round((min(ys) + max(ys)) / 2)


async def _load(browser: Any, driver: VirtualDriver) -> None:
    await asyncio.to_thread(browser.get, driver.url)
    await wait_js(browser, "window.facesynth.status === 'open' && window.facesynth.profile")


async def _face_drawn(browser: Any, seq: int) -> None:
    await wait_js(browser, f"window.facesynth.face && window.facesynth.face.seq === {seq}")


async def test_the_page_draws_the_face_the_commands_describe(browser: Any) -> None:
    driver = await start_driver()
    try:
        await _load(browser, driver)
        assert await js(browser, "return window.facesynth.profile") == "virtual"
        await driver.send(NEUTRAL, CommandInfo(1, None, True))
        await _face_drawn(browser, 1)
        before = await js(browser, f"return {CANVAS_SUM}")
        x, y = _mouth_centre(OPEN)
        assert await js(browser, f"return {PIXEL}", "face", x, y) != _rgb(MOUTH)

        await driver.send(OPEN, CommandInfo(2, None, True))
        await _face_drawn(browser, 2)
        drawn = await js(browser, "return window.facesynth.face.shapes")
        expected = json.loads(msgspec.json.encode(face_geometry(OPEN)))
        assert drawn == expected  # the page drew exactly the geometry Python computed
        assert await js(browser, f"return {CANVAS_SUM}") != before
        pixel = await js(browser, f"return {PIXEL}", "face", x, y)
        assert max(abs(a - b) for a, b in zip(pixel, _rgb(MOUTH), strict=True)) <= 2
        bar = await js(
            browser,
            "return Array.from(document.querySelectorAll('.bar'))"
            ".find(r => r.querySelector('.name').textContent === 'jaw')"
            ".querySelector('.value').textContent",
        )
        assert bar == "1000"
    finally:
        await driver.close()


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


async def test_the_page_reconnects_after_the_service_restarts(browser: Any) -> None:
    address = f"127.0.0.1:{_free_port()}"
    driver = await start_driver(http=address)
    try:
        await _load(browser, driver)
        connects = await js(browser, "return window.facesynth.connects")
        await driver.send(NEUTRAL, CommandInfo(1, None, True))
        await _face_drawn(browser, 1)
    finally:
        await driver.close()
    await wait_js(browser, "window.facesynth.status === 'closed'")
    assert await js(browser, "return document.getElementById('status').textContent") == (
        "reconnecting…"
    )
    await asyncio.sleep(1.0)  # down for a while: the page keeps trying
    driver = await start_driver(http=address)
    try:
        await wait_js(browser, f"window.facesynth.connects === {connects + 1}")
        await driver.send(OPEN, CommandInfo(7, None, True))
        await _face_drawn(browser, 7)
        assert await js(browser, "return window.facesynth.status") == "open"
    finally:
        await driver.close()


async def test_the_page_shows_the_rigs_frame_landmarks_and_stages(browser: Any) -> None:
    bus, rig = MemoryBus(), "browser"
    driver = await start_driver(bus=bus, rig=rig)
    try:
        await _load(browser, driver)
        assert driver.server is not None
        for _ in range(100):
            if driver.server.state()["follows_frames"]:
                break
            await asyncio.sleep(0.02)
        await asyncio.sleep(0.6)  # the follow tasks subscribe within their polling period
        coords = [float(v) for _ in range(68) for v in (40.0, 30.0)]  # every point at (40, 30)
        points = Points(
            seq=3,
            t_capture_ns=1,
            t_media_ns=1,
            face=True,
            image_width=160,
            image_height=90,
            sets=[PointSet(scheme="ibug68", dims=2, coords=coords)],
        )
        bus.publish(keys.stage_key(rig, "points"), codec.encode(points))
        await asyncio.sleep(0.3)
        image = np.zeros((90, 160, 3), np.uint8)
        image[:] = (200, 60, 20)  # BGR: a blue frame
        frame = encode_frame(image, seq=3, t_capture_ns=1, t_media_ns=1, quality=95)
        bus.publish(keys.stage_key(rig, "input"), codec.encode(frame))
        stats = ServiceStats(
            service="points",
            instance="cam-1",
            rig=rig,
            t_ns=1,
            uptime_s=1.0,
            received=5,
            published=5,
            dropped=0,
            rejected=0,
            rate_hz=30.0,
            latency_p50_ms=6.5,
        )
        bus.publish(keys.stats_key(rig, "points", "cam-1"), codec.encode(stats))
        await wait_js(browser, "window.facesynth.framesDrawn > 0")
        assert await js(browser, "return [frame.width, frame.height]") == [160, 90]
        landmark = await js(browser, f"return {PIXEL}", "frame", 40, 30)
        background = await js(browser, f"return {PIXEL}", "frame", 120, 70)
        assert landmark[1] > 200 and landmark[0] < 120  # the green dot
        assert abs(background[0] - 20) < 12 and abs(background[2] - 200) < 12  # the frame
        await wait_js(
            browser, "document.querySelector('#stats tbody').textContent.includes('cam-1')"
        )
        row = await js(browser, "return document.querySelector('#stats tbody tr').textContent")
        assert "points" in row and "running" in row and "6.50" in row
    finally:
        await driver.close()


async def test_bad_messages_from_a_browser_are_refused_and_the_page_stays(browser: Any) -> None:
    driver = await start_driver()
    try:
        await _load(browser, driver)
        codes = await asyncio.to_thread(
            browser.execute_async_script,
            """
            const done = arguments[arguments.length - 1];
            const codes = [];
            const tries = ['{"type": "move", "jaw": 1000}', 'x'.repeat(5000), new Uint8Array(8)];
            let left = tries.length;
            for (const message of tries) {
              const ws = new WebSocket('ws://' + location.host + '/ws');
              ws.onopen = () => ws.send(message);
              ws.onclose = (event) => { codes.push(event.code); if (--left === 0) done(codes); };
            }
            """,
        )
        assert sorted(codes) == [1003, 1008, 1009]
        assert driver.server is not None and driver.server.refused == 3
        await driver.send(OPEN, CommandInfo(4, None, True))
        await _face_drawn(browser, 4)  # the page itself was never disturbed
        assert await js(browser, "return window.facesynth.connects") == 1
    finally:
        await driver.close()


async def test_a_browser_among_several_pages_and_a_stalled_one(browser: Any) -> None:
    driver = await start_driver()
    try:
        await _load(browser, driver)
        async with aiohttp.ClientSession() as session:
            stalled = await session.ws_connect(driver.url + "ws")  # never read
            pages = [await open_page(session, driver) for _ in range(3)]
            assert driver.server is not None
            timings = []
            for seq in range(1, 301):
                started = time.perf_counter()
                await driver.send({**NEUTRAL, "jaw": float(seq)}, CommandInfo(seq, None, True))
                timings.append(time.perf_counter() - started)
                if seq % 100 == 0:
                    driver.server.fanout.offer("frame", b"\x00" * 500_000)
                await asyncio.sleep(0.003)
            await _face_drawn(browser, 300)
            for page in pages:
                seen = -1
                while seen != 300:
                    seen = (await page.next("face"))["seq"]
            assert driver.server.state()["clients"] == 5
            assert sorted(timings)[150] < 0.01
            await stalled.close()
    finally:
        await driver.close()
