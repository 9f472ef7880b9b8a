"""The five services as separate OS processes on a real loopback Zenoh router.

Checks that servo commands for a known input (the real OpenFace CSV) come out with the values
the pure cores compute, that they equal what ``facesynth run`` gives in one process, and that
malformed messages on every key are counted and dropped without crashing any service.
"""

from __future__ import annotations

import asyncio
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from facesynth.app.data import sample_openface_csv
from facesynth.runtime import codec, keys
from facesynth.runtime.bus.zenoh_bus import ZenohBus, ZenohOptions
from facesynth.runtime.profiles import load_profile
from facesynth.schemas.messages import (
    Features,
    Frame,
    Points,
    PointSet,
    ServiceStats,
    ServoCommands,
)
from facesynth.services.control.drivers.record import RecordLine, read_record
from facesynth.services.features.core import FeatureProcessor
from facesynth.services.points.backends.openface import OpenFaceConfig, OpenFaceReplay
from facesynth.services.translator.core import Translator

CSV = str(sample_openface_csv())
FPS = 30.0
SERVICES = ["points", "features", "translator", "control"]


def start_downstream(
    spawn: Any, locator: str, rig: str, out: Path
) -> dict[str, subprocess.Popen[bytes]]:
    common = ["--connect", locator, "--rig", rig, "--stats-interval", "0.2"]
    return {
        "control": spawn(
            "control",
            "--profile",
            "paper16",
            "--driver",
            "record",
            "--out",
            str(out),
            "--motion-time",  # the sensor is --fast: speed limits on the commands' media time
            "media",
            *common,
            name="control",
        ),
        "translator": spawn("translator", "--profile", "paper16", *common, name="translator"),
        "features": spawn("features", *common, name="features"),
        "points": spawn("points", "--openface-csv", CSV, *common, name="points"),
    }


def frame_lines(path: Path) -> list[RecordLine]:
    return [line for line in read_record(path) if line.frame is not None]


def wait_for_frames(path: Path, count: int, timeout: float) -> list[RecordLine]:
    deadline = time.monotonic() + timeout
    lines: list[RecordLine] = []
    while time.monotonic() < deadline:
        if path.exists():
            lines = frame_lines(path)
            if len(lines) >= count:
                return lines
        time.sleep(0.1)
    raise AssertionError(f"only {len(lines)} of {count} commands were recorded")


def expected_commands(
    profile: str = "paper16", frames: int | None = None
) -> list[dict[str, float]]:
    """The commands the pure cores give for the CSV replayed at 30 fps through ``profile``
    (its first ``frames`` frames; default all)."""
    replay = OpenFaceReplay(OpenFaceConfig(csv=str(CSV)))
    processor = FeatureProcessor(neutral_seconds=1.0)
    translator = Translator(load_profile(profile))
    out = []
    for seq in range(replay.frame_count() if frames is None else frames):
        frame = Frame(
            seq=seq,
            t_capture_ns=1,
            t_media_ns=round(seq * 1e9 / FPS),
            width=640,
            height=480,
            encoding="none",
        )
        commands = translator.translate(processor.process(replay.process(frame)))
        out.append(commands.positions)
    return out


def test_five_processes_match_pure_cores_and_run(
    spawn: Any, zenoh_router: str, rig: str, tmp_path: Path
) -> None:
    record = tmp_path / "processes.jsonl"
    procs = start_downstream(spawn, zenoh_router, rig, record)
    sensor = spawn(
        "sensor",
        "--ticks",
        "100",
        "--fps",
        str(FPS),
        "--fast",
        "--connect",
        zenoh_router,
        "--rig",
        rig,
        "--wait-for",
        ",".join(SERVICES),
        name="sensor",
    )
    assert sensor.wait(timeout=60) == 0, spawn.log("sensor")
    lines = wait_for_frames(record, 100, timeout=30)
    for name, proc in procs.items():
        assert proc.poll() is None, f"{name} died:\n{spawn.log(name)}"
        proc.send_signal(signal.SIGTERM)
    for name, proc in procs.items():
        assert proc.wait(timeout=15) == 0, f"{name} did not stop cleanly:\n{spawn.log(name)}"

    assert [line.frame for line in lines] == list(range(100))
    expected = expected_commands()
    moved = 0
    for line, positions in zip(lines, expected, strict=True):
        assert line.servos.keys() == positions.keys()
        for name, value in positions.items():
            assert line.servos[name] == pytest.approx(value, abs=1e-3), (line.frame, name)
        moved += any(abs(v - 1500.0) > 1.0 for v in positions.values())
    assert moved > 50, "the known input must move the servos, or this comparison proves little"
    # The face goes back to neutral when the control interface stops.
    final = read_record(record)[-1]
    assert final.frame is None and set(final.servos.values()) == {1500.0}

    in_process = tmp_path / "run.jsonl"
    run = subprocess.run(
        [
            sys.executable,
            "-m",
            "facesynth",
            "run",
            "--openface-csv",
            CSV,
            "--fast",
            "--fps",
            str(FPS),
            "--out",
            str(in_process),
            "--listen",
            "tcp/127.0.0.1:0",
            "--rig",
            rig + "r",
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert run.returncode == 0, run.stderr
    run_lines = frame_lines(in_process)
    assert [line.frame for line in run_lines] == list(range(100))
    assert [line.servos for line in run_lines] == [line.servos for line in lines]


GARBAGE = [b"", b"\x00\x01\x02", b"\x81\xa4type\xa5frame", b'{"json": true}', b"\xc1" * 64]


async def _stats_by_service(
    bus: ZenohBus, rig: str, want: dict[str, int], timeout: float
) -> dict[str, ServiceStats]:
    subscription = bus.subscribe_queued(keys.stats_pattern(rig), 256)
    latest: dict[str, ServiceStats] = {}
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            sample = await asyncio.wait_for(subscription.receive(), 0.5)
        except TimeoutError:
            continue
        stats = codec.decode(sample.payload, ServiceStats)
        latest[stats.service] = stats
        if all(s in latest and latest[s].rejected >= n for s, n in want.items()):
            break
    subscription.close()
    return latest


def bad_messages() -> list[tuple[str, bytes]]:
    """Garbage, wrong types, and well-formed messages with NaN or wrong shapes, per stage."""
    nan_points = codec.encode(
        Points(
            seq=1,
            t_capture_ns=1,
            t_media_ns=1,
            face=True,
            image_width=640,
            image_height=480,
            sets=[PointSet(scheme="ibug68", dims=2, coords=[float("nan")] * 136)],
        )
    )
    nan_features = codec.encode(
        Features(
            seq=1,
            t_capture_ns=1,
            t_media_ns=1,
            face=True,
            neutral_ready=True,
            distances=[1.0] * 68,
            deltas=[float("inf")] * 68,
        )
    )
    short_features = codec.encode(
        Features(
            seq=1,
            t_capture_ns=1,
            t_media_ns=1,
            face=True,
            neutral_ready=True,
            distances=[1.0] * 3,
            deltas=[0.0] * 3,
        )
    )
    wild_commands = codec.encode(
        ServoCommands(
            seq=1,
            t_capture_ns=1,
            t_media_ns=1,
            face=True,
            profile="paper16",
            positions={"jaw": float("nan")},
        )
    )
    unknown_servo = codec.encode(
        ServoCommands(
            seq=1,
            t_capture_ns=1,
            t_media_ns=1,
            face=True,
            profile="paper16",
            positions={"tail": 1500.0},
        )
    )
    other_profile = codec.encode(
        ServoCommands(
            seq=1,
            t_capture_ns=1,
            t_media_ns=1,
            face=True,
            profile="other",
            positions={"jaw": 1500.0},
        )
    )
    frame_as_points = codec.encode(
        Frame(seq=1, t_capture_ns=1, t_media_ns=1, width=4, height=4, encoding="none")
    )
    out = []
    for stage in ("input", "points", "features", "servo_commands"):
        out.extend((stage, payload) for payload in GARBAGE)
    out += [
        ("points", nan_points),
        ("points", frame_as_points),
        ("features", nan_features),
        ("features", short_features),
        ("servo_commands", wild_commands),
        ("servo_commands", unknown_servo),
        ("servo_commands", other_profile),
    ]
    return out


def test_malformed_messages_on_every_key_are_counted_and_dropped(
    spawn: Any, zenoh_router: str, rig: str, tmp_path: Path
) -> None:
    record = tmp_path / "commands.jsonl"
    procs = start_downstream(spawn, zenoh_router, rig, record)
    messages = bad_messages()
    per_service = {"points": 0, "features": 0, "translator": 0, "control": 0}
    consumer = {
        "input": "points",
        "points": "features",
        "features": "translator",
        "servo_commands": "control",
    }
    for stage, _ in messages:
        per_service[consumer[stage]] += 1

    async def attack() -> dict[str, ServiceStats]:
        bus = ZenohBus.open(ZenohOptions(mode="client", connect=[zenoh_router]))
        try:
            deadline = time.monotonic() + 30
            while set(SERVICES) - {
                keys.parse_service_key(k)[1] for k in await bus.alive(keys.health_pattern(rig))
            }:  # type: ignore[index]
                assert time.monotonic() < deadline, "services did not come up"
                await asyncio.sleep(0.1)
            await asyncio.sleep(0.3)
            for stage, payload in messages:
                bus.publish(keys.stage_key(rig, stage), payload)  # type: ignore[arg-type]
                await asyncio.sleep(0.01)
            return await _stats_by_service(bus, rig, per_service, timeout=20)
        finally:
            await bus.close()

    stats = asyncio.run(attack())
    for service, count in per_service.items():
        assert service in stats, f"no stats from {service}"
        assert stats[service].rejected == count, (service, stats[service])
        assert procs[service].poll() is None, f"{service} crashed:\n{spawn.log(service)}"
        assert "dropped a message" in spawn.log(service)
    # Nothing bad reached the servos: only the start-up neutral was recorded.
    lines = read_record(record)
    assert [line.frame for line in lines] == [None]
    assert all(np.isfinite(v) for line in lines for v in line.servos.values())
