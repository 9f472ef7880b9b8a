"""The real tracker in the chain: `facesynth track`, `run --video`, and P as its own process."""

from __future__ import annotations

import asyncio
import json
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from facesynth.app.data import sample_video
from facesynth.runtime import codec, keys
from facesynth.runtime.bus.zenoh_bus import ZenohBus, ZenohOptions
from facesynth.schemas.messages import Points
from facesynth.services.control.drivers.record import read_record

VIDEO = str(sample_video())
FRAMES = 48


def _facesynth(*args: str, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "facesynth", *args], capture_output=True, text=True, timeout=timeout
    )


def test_track_writes_one_line_per_frame(tmp_path: Path) -> None:
    clip = tmp_path / "clip.mp4"
    _cut(VIDEO, clip, 30)
    out = tmp_path / "track.jsonl"
    result = _facesynth("track", str(clip), "--out", str(out))
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert summary["frames"] == 30 and summary["faces"] == 30
    lines = [json.loads(line) for line in out.read_text().splitlines()]
    assert [line["frame"] for line in lines] == list(range(30))
    first = lines[0]
    assert set(first) >= {"frame", "face", "mesh", "iris", "ibug68"}
    assert (len(first["mesh"]), len(first["iris"]), len(first["ibug68"])) == (468, 10, 68)
    # The track file replays through P like any recording.
    replay = _facesynth(
        "run",
        "--points-jsonl",
        str(out),
        "--fast",
        "--out",
        str(tmp_path / "r.jsonl"),
        "--listen",
        "tcp/127.0.0.1:0",
    )
    assert replay.returncode == 0, replay.stderr
    assert sum(1 for line in read_record(tmp_path / "r.jsonl") if line.face) == 30


def _cut(source: str, target: Path, frames: int) -> None:
    import cv2

    capture = cv2.VideoCapture(source)
    writer = cv2.VideoWriter(str(target), cv2.VideoWriter_fourcc(*"mp4v"), 24.0, (640, 360))
    for _ in range(frames):
        ok, image = capture.read()
        assert ok
        writer.write(image)
    writer.release()
    capture.release()


def test_points_process_publishes_the_full_models_points_and_blendshapes(
    spawn: Any, zenoh_router: str, rig: str, tmp_path: Path
) -> None:
    common = ["--connect", zenoh_router, "--rig", rig]
    spawn("points", *common, name="points")

    async def listen() -> list[Points]:
        bus = ZenohBus.open(ZenohOptions(mode="client", connect=[zenoh_router]))
        try:
            subscription = bus.subscribe_queued(keys.stage_key(rig, "points"), 64)
            await asyncio.sleep(0.3)
            sensor = await asyncio.create_subprocess_exec(
                sys.executable,
                "-m",
                "facesynth",
                "sensor",
                "--video",
                VIDEO,
                "--max-frames",
                "10",
                "--wait-for",
                "points",
                *common,
                stdout=asyncio.subprocess.DEVNULL,
                stderr=asyncio.subprocess.DEVNULL,
            )
            assert await asyncio.wait_for(sensor.wait(), 60) == 0
            got = []
            deadline = time.monotonic() + 30
            while len(got) < 10 and time.monotonic() < deadline:
                sample = await asyncio.wait_for(subscription.receive(), 30)
                got.append(codec.decode(sample.payload, Points))
            return got
        finally:
            await bus.close()

    points = asyncio.run(listen())
    assert [p.seq for p in points] == list(range(10)), spawn.log("points")
    for message in points:
        assert message.face and message.source == "tracker"
        dims = {s.scheme: (s.dims, len(s.coords)) for s in message.sets}
        # the default (full) model: 478 points with the irises, and the blendshapes
        assert dims == {"ibug68": (2, 136), "mesh478": (3, 1434), "iris10": (2, 20)}
        assert [(s.scheme, len(s.values)) for s in message.scores] == [("blendshapes52", 52)]


def test_tracker_chain_in_processes_matches_run(
    spawn: Any, zenoh_router: str, rig: str, tmp_path: Path
) -> None:
    record = tmp_path / "processes.jsonl"
    common = ["--connect", zenoh_router, "--rig", rig]
    # The sensor is --fast: speed limits on the commands' media time, as `run --fast` does.
    spawn(
        "control",
        "--driver",
        "record",
        "--out",
        str(record),
        "--motion-time",
        "media",
        *common,
        name="control",
    )
    spawn("translator", *common, name="translator")
    spawn("features", *common, name="features")
    spawn("points", *common, name="points")
    sensor = spawn(
        "sensor",
        "--video",
        VIDEO,
        "--fast",
        "--max-frames",
        str(FRAMES),
        "--wait-for",
        "points,features,translator,control",
        *common,
        name="sensor",
    )
    assert sensor.wait(timeout=120) == 0, spawn.log("sensor")
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        lines = [line for line in read_record(record) if line.frame is not None]
        if len(lines) >= FRAMES:
            break
        time.sleep(0.1)
    run = _facesynth(
        "run",
        "--video",
        VIDEO,
        "--fast",
        "--encoding",
        "jpeg",  # P tracks the JPEG the processes' P gets (the default: the raw pixels)
        "--max-frames",
        str(FRAMES),
        "--out",
        str(tmp_path / "run.jsonl"),
        "--listen",
        "tcp/127.0.0.1:0",
    )
    assert run.returncode == 0, run.stderr
    in_process = [line for line in read_record(tmp_path / "run.jsonl") if line.frame is not None]
    assert [line.frame for line in lines] == list(range(FRAMES))
    assert all(line.face for line in lines)
    assert [line.servos for line in lines] == [line.servos for line in in_process]
    moving = {name for line in lines for name, value in line.servos.items() if value != 1500.0}
    # The sample opens on raised (sad) brows: F holds the brows at neutral until they rest
    # (issue 20; not before frame 48), so the brow servos stay; most others move.
    brows = {"right_eyebrow", "left_eyebrow", "middle_eyebrow"}
    assert not moving & brows, f"the brows should be held, moved {sorted(moving & brows)}"
    assert len(moving - brows) >= 10, (
        f"the performer's face should move most servos, moved {sorted(moving)}"
    )
