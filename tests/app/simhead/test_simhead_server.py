"""The simulated head as a device: the real Maestro driver moves it over the pty, its camera
is an MJPEG URL OpenCV opens, and ``facesynth simhead`` runs it as a process."""

from __future__ import annotations

import asyncio
import os
import re
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import cv2
import numpy as np
import pytest

from facesynth.app.simhead import SimHead, load_head
from facesynth.app.simhead.command import parse_address
from facesynth.app.simhead.maestro import Maestro
from facesynth.app.simhead.server import SimHeadServer, SimHeadServerError
from facesynth.runtime.profiles import load_profile
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.maestro import MaestroConfig, MaestroDriver

ROOT = Path(__file__).resolve().parents[3]
INFO = CommandInfo(frame=1, t_capture_ns=None, face=True)
JAW = 11


def _jpeg(url: str) -> np.ndarray:
    with urllib.request.urlopen(url, timeout=5) as response:
        assert response.headers["Content-Type"] == "image/jpeg"
        data = response.read()
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    assert image is not None and image.shape == (320, 320, 3)
    return image


def _mjpeg_frames(url: str, count: int) -> list[np.ndarray]:
    capture = cv2.VideoCapture(url)
    try:
        assert capture.isOpened(), url
        frames = []
        for _ in range(count):
            ok, image = capture.read()
            assert ok
            frames.append(image)
        return frames
    finally:
        capture.release()


def _lower_face_change(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a[200:300].astype(int) - b[200:300]).mean())


async def test_the_maestro_driver_moves_the_head_and_the_camera_shows_it(tmp_path: Path) -> None:
    link = tmp_path / "tty"
    server = SimHeadServer(SimHead(load_head("simhead16")), Maestro(), link, fps=30)
    await server.start()
    profile = load_profile("paper16")
    driver = MaestroDriver(MaestroConfig(port=str(link), model="mini24"), profile)
    try:
        assert link.is_symlink() and os.readlink(link) == server.device
        frames = await asyncio.to_thread(_mjpeg_frames, server.url, 3)
        rest = await asyncio.to_thread(_jpeg, server.snapshot_url)
        await driver.connect()
        neutral = {s.name: s.neutral_us for s in profile.servos}
        await driver.send({**neutral, "jaw": 2000.0}, INFO)
        deadline = time.monotonic() + 5
        while server.head.positions()[JAW] < 1990 and time.monotonic() < deadline:
            await asyncio.sleep(0.02)
        assert server.head.positions()[JAW] >= 1990
        assert server.maestro.limits(JAW)[0] > 0  # the driver set paper16's jaw speed limit
        assert server.maestro.errors == 0 and server.maestro.error_events == 0
        await asyncio.sleep(0.1)
        opened = await asyncio.to_thread(_mjpeg_frames, server.url, 2)
        assert _lower_face_change(frames[-1], rest) < 3  # JPEG noise only
        assert _lower_face_change(opened[-1], rest) > 5  # the jaw dropped
        assert server.frames_served >= 5
    finally:
        await driver.close()
        await server.stop()
    assert not link.exists()


async def test_bad_links_and_addresses(tmp_path: Path) -> None:
    taken = tmp_path / "file"
    taken.write_text("not a link")
    head = SimHead(load_head("simhead16"))
    with pytest.raises(SimHeadServerError, match="exists and is not a symlink"):
        await SimHeadServer(head, Maestro(), taken).start()
    with pytest.raises(SimHeadServerError, match="is not a folder"):
        await SimHeadServer(head, Maestro(), tmp_path / "nowhere" / "tty").start()
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        server = SimHeadServer(head, Maestro(), tmp_path / "tty", port=port)
        with pytest.raises(SimHeadServerError, match=f"cannot listen on 127.0.0.1:{port}"):
            await server.start()
    assert not (tmp_path / "tty").exists()
    with pytest.raises(SimHeadServerError, match="--fps 0 is not within"):
        SimHeadServer(head, Maestro(), tmp_path / "tty", fps=0)
    with pytest.raises(SimHeadServerError, match="--noise -1 is not within"):
        SimHeadServer(head, Maestro(), tmp_path / "tty", noise=-1)
    with pytest.raises(SimHeadServerError, match="cannot make the link /proc/tty-here"):
        await SimHeadServer(head, Maestro(), Path("/proc/tty-here")).start()
    for bad in ("8090", "host:", ":80", "host:99999", "host:http"):
        with pytest.raises(SimHeadServerError, match="is not HOST:PORT"):
            parse_address(bad)
    assert parse_address("[::1]:0") == ("::1", 0)


@pytest.mark.slow
async def test_the_simhead_command_end_to_end(tmp_path: Path) -> None:
    """``facesynth simhead`` as a process: the Maestro driver moves it, Ctrl-C stops it."""
    link = tmp_path / "simhead-tty"
    process = subprocess.Popen(
        [
            *(sys.executable, "-m", "facesynth", "simhead", "simhead16_reversed"),
            *("--serial-link", str(link), "--http", "127.0.0.1:0", "--fps", "20"),
        ],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert process.stdout is not None
        lines = [process.stdout.readline() for _ in range(4)]
        text = "".join(lines)
        assert "simhead: head simhead16_reversed (16 actuators)" in text, text
        assert f"serial port: {link} -> /dev/pts/" in text
        url = re.search(r"camera: (http://\S+/camera\.mjpg) \(snapshot (\S+)\)", text)
        assert url is not None, text
        rest = await asyncio.to_thread(_jpeg, url.group(2))
        profile = load_profile("paper16")
        driver = MaestroDriver(MaestroConfig(port=str(link), model="mini24"), profile)
        await driver.connect()
        try:
            neutral = {s.name: s.neutral_us for s in profile.servos}
            await driver.send({**neutral, "jaw": 2000.0}, INFO)
            deadline = time.monotonic() + 10
            while time.monotonic() < deadline:  # until the camera shows the jaw dropped
                now = await asyncio.to_thread(_jpeg, url.group(2))
                if _lower_face_change(now, rest) > 5:
                    break
                await asyncio.sleep(0.05)
        finally:
            await driver.close()
        frames = await asyncio.to_thread(_mjpeg_frames, url.group(1), 2)
        assert _lower_face_change(frames[-1], rest) > 5
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=10) == 0
        assert not link.exists()
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()


async def test_a_driver_may_close_the_port_and_come_back(tmp_path: Path) -> None:
    link = tmp_path / "tty"
    server = SimHeadServer(SimHead(load_head("simhead16")), Maestro(), link)
    await server.start()
    profile = load_profile("paper16")
    try:
        for pulse in (1200.0, 1800.0):
            driver = MaestroDriver(MaestroConfig(port=str(link), model="mini24"), profile)
            await driver.connect()
            try:
                neutral = {s.name: s.neutral_us for s in profile.servos}
                await driver.send({**neutral, "right_eyebrow": pulse}, INFO)
                deadline = time.monotonic() + 5
                while server.maestro.targets()[0] != pulse and time.monotonic() < deadline:
                    await asyncio.sleep(0.02)
                assert server.maestro.targets()[0] == pulse
            finally:
                await driver.close()
        assert server.maestro.error_events == 0
    finally:
        await server.stop()


def test_list_and_bench(capsys: pytest.CaptureFixture[str]) -> None:
    from facesynth.app.cli import main

    assert main(["simhead", "--list"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("simhead16: The default simulated head")
    assert "simhead16_reversed: " in out and "simhead16_stiff: " in out
    assert main(["simhead", "simhead16_stiff", "--bench", "5"]) == 0
    out = capsys.readouterr().out
    assert re.match(r"simhead simhead16_stiff: 5 frames of 320x320: mean \d+\.\d\d ms", out)
