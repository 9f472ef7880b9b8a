"""One performer, two robots of different profiles, on a real loopback Zenoh router.

The performer's chain (sensor, points from the real OpenFace CSV, features) runs as processes;
robot ``a`` (paper16) as a translator process and a control process of its own, robot ``b``
(head16) as both nodes in one ``facesynth run`` of a graph without a sensor. Each robot's
commands must be exactly what the pure cores give for its profile, neither control interface
may refuse the other's commands as noise (each has its own keys), a control interface still
refuses another profile's commands on its key, and every process stops cleanly. The sensor is
``--fast``, so the control interfaces measure speed limits on the commands' media time
(``motion_time = "media"``), as a real-time replay would on the wall clock.
"""

from __future__ import annotations

import asyncio
import signal
from pathlib import Path
from typing import Any

import pytest
from test_chain_processes import FPS, expected_commands, wait_for_frames

from facesynth.app.data import sample_openface_csv
from facesynth.runtime import codec, keys
from facesynth.runtime.bus.zenoh_bus import ZenohBus, ZenohOptions
from facesynth.schemas.messages import ServiceStats, ServoCommands
from facesynth.services.control.drivers.record import read_record

CSV = str(sample_openface_csv())
FRAMES = 100


GRAPH = """rig = "{rig}"
[nodes.translator_a]
stage = "translator"
profile = "paper16"
robot = "a"
[nodes.control_a]
stage = "control"
profile = "paper16"
robot = "a"
motion_time = "media"
driver = {{ driver = "record", out = "{out}/a.jsonl" }}
[nodes.translator_b]
stage = "translator"
profile = "head16"
robot = "b"
[nodes.control_b]
stage = "control"
profile = "head16"
robot = "b"
motion_time = "media"
driver = {{ driver = "record", out = "{out}/b.jsonl" }}
"""
SHARED = """rig = "{rig}"
[nodes.translator_b]
stage = "translator"
profile = "head16"
robot = "b"
[nodes.control_b]
stage = "control"
profile = "head16"
robot = "b"
motion_time = "media"
driver = {{ driver = "record", out = "{out}/b.jsonl" }}
"""


async def _all_alive(locator: str, rig: str, count: int, timeout: float) -> None:
    bus = ZenohBus.open(ZenohOptions(mode="client", connect=[locator]))
    try:
        deadline = asyncio.get_running_loop().time() + timeout
        while len(alive := await bus.alive(keys.health_pattern(rig))) < count:
            assert asyncio.get_running_loop().time() < deadline, f"only alive: {alive}"
            await asyncio.sleep(0.2)
    finally:
        await bus.close()


async def _refusals(locator: str, rig: str, instance_part: str, timeout: float) -> ServiceStats:
    """Publish head16 commands on robot a's key until its control refuses one; its stats then.

    (The first publication of a freshly declared Zenoh publisher can be lost, measured with and
    without facesynth's bus: so publish again until one arrives.)"""
    bus = ZenohBus.open(ZenohOptions(mode="client", connect=[locator]))
    try:
        stats = bus.subscribe_queued(keys.stats_pattern(rig), 256)
        wrong = ServoCommands(
            seq=10_000,
            t_capture_ns=1,
            t_media_ns=1,
            face=True,
            profile="head16",
            positions={"jaw": 1600.0},
        )
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout
        while loop.time() < deadline:
            try:
                sample = await asyncio.wait_for(stats.receive(), 0.5)
            except TimeoutError:
                continue
            message = codec.decode(sample.payload, ServiceStats)
            if message.service != "control" or instance_part not in message.instance:
                continue
            if message.rejected:
                return message
            bus.publish(keys.stage_key(rig, "servo_commands", "a"), codec.encode(wrong))
        raise AssertionError("robot a never refused the head16 commands")
    finally:
        await bus.close()


def test_two_robots_share_one_performer(
    spawn: Any, zenoh_router: str, rig: str, tmp_path: Path
) -> None:
    graph = tmp_path / "robots.toml"
    graph.write_text(GRAPH.format(rig=rig, out=tmp_path))
    shared = tmp_path / "shared.toml"
    shared.write_text(SHARED.format(rig=rig, out=tmp_path))
    common = ["--connect", zenoh_router, "--rig", rig, "--stats-interval", "0.2"]
    robots = {
        "control_a": spawn(
            "control", "--graph", str(graph), "--node", "control_a", *common, name="control_a"
        ),
        "translator_a": spawn(
            "translator",
            "--graph",
            str(graph),
            "--node",
            "translator_a",
            *common,
            name="translator_a",
        ),
        "robot_b": spawn("run", str(shared), "--mode", "client", *common, name="robot_b"),
    }
    performer = {
        "features": spawn("features", *common, name="features"),
        "points": spawn("points", "--openface-csv", CSV, *common, name="points"),
    }
    # --wait-for names services, which one robot's satisfy: wait for all six nodes here.
    asyncio.run(_all_alive(zenoh_router, rig, 6, timeout=60))
    sensor = spawn(
        "sensor",
        "--ticks",
        str(FRAMES),
        "--fps",
        str(FPS),
        "--fast",
        *common,
        "--wait-for",
        "points,features,translator,control",
        name="sensor",
    )
    assert sensor.wait(timeout=90) == 0, spawn.log("sensor")
    lines = {robot: wait_for_frames(tmp_path / f"{robot}.jsonl", FRAMES, 30) for robot in "ab"}
    for robot, profile in (("a", "paper16"), ("b", "head16")):
        assert [line.frame for line in lines[robot]] == list(range(FRAMES))
        moved = 0
        for line, positions in zip(lines[robot], expected_commands(profile, FRAMES), strict=True):
            assert line.servos == pytest.approx(positions, abs=1e-3), (robot, line.frame)
            moved += any(abs(v - 1500.0) > 1.0 for v in positions.values())
        assert moved > 30, f"robot {robot}: the input must move the servos"

    stats = asyncio.run(_refusals(zenoh_router, rig, "control_a", timeout=15))
    # It refused what it got of those, and nothing else (not robot b's commands either).
    assert stats.rejected == stats.received - FRAMES >= 1, stats
    assert all(line.frame != 10_000 for line in read_record(tmp_path / "a.jsonl"))
    for name, proc in {**robots, **performer}.items():
        assert proc.poll() is None, f"{name} died:\n{spawn.log(name)}"
        proc.send_signal(signal.SIGTERM)
    for name, proc in {**robots, **performer}.items():
        assert proc.wait(timeout=15) == 0, f"{name} did not stop cleanly:\n{spawn.log(name)}"
    assert '"nodes": ["translator_b", "control_b"]' in spawn.log("robot_b")
