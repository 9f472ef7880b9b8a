"""The performer calibration from the console: the page sees the performer's frames, the
landmarks and a countdown per expression, then the file written (or why not)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import aiohttp
from console_token import TOKEN

from facesynth.app.cli import build_parser
from facesynth.app.console.calibration import CalibrationRun
from facesynth.app.console.server import ConsoleServer
from facesynth.app.data import sample_video
from facesynth.runtime.calibration import load_calibration
from facesynth.services.control.drivers.virtual import wire


async def test_a_calibration_from_a_video_is_shown_and_saved(
    console: ConsoleServer, tmp_path: Path
) -> None:
    args = build_parser().parse_args(
        ["console", "--video", str(sample_video()), "--schedule", "neutral=0-1,smile=1-1.6"]
    )
    console.calibration = lambda name: CalibrationRun(name, args, tmp_path)
    seen: list[dict[str, Any]] = []
    frames = 0
    async with aiohttp.ClientSession() as http:
        ws = await http.ws_connect(f"http://127.0.0.1:{console.port}/ws")
        await ws.send_str(json.dumps({"type": "hello", "token": TOKEN}))
        await ws.send_str(json.dumps({"type": "calibrate", "name": "bad name"}))
        await ws.send_str(json.dumps({"type": "calibrate", "name": "alice"}))
        await ws.send_str(json.dumps({"type": "calibrate", "name": "bob"}))
        errors = []
        while not seen or seen[-1].get("state") not in ("done", "failed"):
            msg = await ws.receive(timeout=60)
            if msg.type == aiohttp.WSMsgType.BINARY:
                header, pixels = wire.read_frame(msg.data)
                assert header["encoding"] == "jpeg" and pixels[:2] == b"\xff\xd8"
                frames += 1
                continue
            message = json.loads(msg.data)
            if message["type"] == "calibration":
                seen.append(message)
            elif message["type"] == "error":
                errors.append(message["message"])
            elif message["type"] == "points":
                assert len(message["ibug68"]) in (0, 136)
    assert seen[-1]["state"] == "done", seen[-1]
    assert "calibration name" in errors[0] and "'bob'" not in errors[0]
    assert errors[1] == "calibration 'alice' is running"
    steps = [m["step"] for m in seen if m["state"] == "running"]
    assert steps[0] == "neutral" and "smile" in steps
    countdown = [m["left_s"] for m in seen if m["state"] == "running" and m["step"] == "neutral"]
    assert countdown[0] > countdown[-1] >= 0  # a countdown per expression
    assert frames >= 5
    path = tmp_path / "alice.json"
    assert seen[-1]["path"] == str(path)
    assert load_calibration(str(path)).name == "alice"
    assert console.calibrating is None


async def test_a_failed_calibration_says_why(console: ConsoleServer, tmp_path: Path) -> None:
    args = build_parser().parse_args(["console", "--video", str(sample_video())])
    console.calibration = lambda name: CalibrationRun(name, args, tmp_path)
    async with aiohttp.ClientSession() as http:
        ws = await http.ws_connect(f"http://127.0.0.1:{console.port}/ws")
        await ws.send_str(json.dumps({"type": "hello", "token": TOKEN}))
        await ws.send_str(json.dumps({"type": "calibrate", "name": "carol"}))
        while True:
            message = json.loads((await ws.receive(timeout=60)).data)
            if message["type"] == "calibration" and message["state"] == "failed":
                break
    assert "give --schedule" in message["error"]  # a video has no prompts
    assert not (tmp_path / "carol.json").exists()
