"""The ``ros2`` driver against a real rclpy subscriber in another process.

The performer video's chain (one ``facesynth run``) drives a robot of four control nodes (another
``facesynth run``, started first, so every node is up before the first frame) on the same
commands: the ``record`` driver and the ``ros2`` driver in its three forms (JointState,
JointTrajectory, Float64MultiArray). The profile is paper16 without speed limits and with a
neutral ramp of 0 and commands up to 5 s old executed, so each control node sends exactly the
translator's commands whatever its timing: every command of the record file must arrive on
ROS 2, in radians of the profile's angle maps (one servo with a map of its own), stamped with
its frame's capture time, and the last one neutral.
"""

from __future__ import annotations

import asyncio
import math
import re
import signal
import subprocess
import time
from collections.abc import Callable
from pathlib import Path

from facesynth_processes import Processes
from ros2_peers import Received, read_received, subscriber

from facesynth.runtime import keys
from facesynth.runtime.bus.zenoh_bus import ZenohBus, ZenohOptions
from facesynth.runtime.profiles import PACKAGE_DIR, Profile, parse_profile
from facesynth.services.control.drivers.record import RecordLine, read_record

FRAMES = 150
TOPICS = {
    "/facesynth/joint_commands": "joint_state",
    "/head/trajectory": "trajectory",
    "/head/commands": "array",
}
#: The jaw's own angle map: 1000-2000 µs over -45..45°.
JAW_ANGLE = "angle = { min_us = 1000, max_us = 2000, min_deg = -45, max_deg = 45 }\n"


def unlimited_profile(folder: Path) -> tuple[Path, Profile]:
    """paper16 without speed limits, with a neutral ramp of 0, commands executed up to 5 s
    old, and the jaw's own angle map."""
    text = _paper16_text()
    text = re.sub(r"(?m)^max_(speed|accel) = .*\n", "", text)
    text = re.sub(r"(?m)^neutral_ramp_s = .*$", "neutral_ramp_s = 0", text)
    # Each node judges a command's age on its own: on a loaded machine the node that takes it
    # after the record node could drop one captured 0.25 s ago that the record node executed.
    text = text.replace("neutral_ramp_s = 0\n", "neutral_ramp_s = 0\nmax_command_age_s = 5\n", 1)
    text = re.sub(r'(?m)^name = "paper16"$', 'name = "paper16_ros2"', text)
    text = text.replace('name = "jaw"\n', 'name = "jaw"\n' + JAW_ANGLE, 1)
    path = folder / "paper16_ros2.toml"
    path.write_text(text)
    return path, parse_profile(text)


def _paper16_text() -> str:
    return (Path(PACKAGE_DIR) / "paper16.toml").read_text()


RIG = "ros2test"


def graphs(folder: Path, profile: Path, *, video_loop: bool = False) -> tuple[Path, Path]:
    """The performer's graph (sensor to translator) and the robot's (four control nodes)."""
    performer, robot = folder / "performer.toml", folder / "robot.toml"
    loop = "true" if video_loop else "false"
    performer.write_text(
        f"""rig = "{RIG}"
[nodes.sensor]
stage = "sensor"
source = {{ source = "video", loop = {loop} }}
[nodes.points]
stage = "points"
backend = {{ backend = "tracker" }}
[nodes.features]
stage = "features"
[nodes.translator]
stage = "translator"
profile = "{profile}"
"""
    )
    robot.write_text(
        f"""rig = "{RIG}"
[nodes.record]
stage = "control"
profile = "{profile}"
driver = {{ driver = "record", out = "{folder}/commands.jsonl" }}
[nodes.joints]
stage = "control"
profile = "{profile}"
driver = {{ driver = "ros2", node = "facesynth_joints" }}
[nodes.trajectory]
stage = "control"
profile = "{profile}"
[nodes.trajectory.driver]
driver = "ros2"
output = "trajectory"
topic = "/head/trajectory"
node = "facesynth_trajectory"
[nodes.array]
stage = "control"
profile = "{profile}"
[nodes.array.driver]
driver = "ros2"
output = "array"
topic = "/head/commands"
node = "facesynth_array"
"""
    )
    return performer, robot


async def _alive(router: str, count: int, timeout: float, proc: subprocess.Popen[bytes]) -> None:
    bus = ZenohBus.open(ZenohOptions(mode="client", connect=[router]))
    try:
        deadline = asyncio.get_running_loop().time() + timeout
        while len(alive := await bus.alive(keys.health_pattern(RIG))) < count:
            assert proc.poll() is None, "the robot's facesynth run ended"
            assert asyncio.get_running_loop().time() < deadline, f"only alive: {alive}"
            await asyncio.sleep(0.1)
    finally:
        await bus.close()


def start_robot(procs: Processes, router: str, robot: Path) -> subprocess.Popen[bytes]:
    """The robot's four control nodes in one ``facesynth run``, once all four are up (their
    drivers connected, the ros2 ones discovered by the subscriber)."""
    proc = procs.start("run", str(robot), "--mode", "client", "--connect", router, name="robot")
    try:
        asyncio.run(_alive(router, 4, timeout=90, proc=proc))
    except AssertionError as exc:
        raise AssertionError(f"{exc}:\n{procs.log('robot')[-3000:]}") from None
    return proc


def start_performer(
    procs: Processes, router: str, performer: Path, *args: str
) -> subprocess.Popen[bytes]:
    return procs.start(
        "run", str(performer), "--mode", "client", "--connect", router, *args, name="performer"
    )


def radians(profile: Profile, line: RecordLine) -> list[float]:
    return [spec.angle.radians(line.servos[spec.name]) for spec in profile.servos]


def close(a: list[float], b: list[float]) -> bool:
    # The record file rounds to 0.001 µs: 1.6e-6 rad on a 0-180° map, 2.4e-6 on the jaw's.
    return len(a) == len(b) and all(abs(x - y) < 1e-5 for x, y in zip(a, b, strict=True))


def on(topic: str, received: list[Received]) -> list[Received]:
    return [r for r in received if r.topic == topic]


def last(messages: list[Received]) -> list[float]:
    """The positions of the last of ``messages`` (none: an empty list)."""
    return messages[-1].positions if messages else []


def settle(out: Path, done: Callable[[list[Received]], bool], timeout: float = 5.0) -> None:
    """Wait until what the subscriber took (its file ``out``) is ``done``, at most ``timeout``
    s: the messages still on their way when facesynth ended (the assertions say what is not)."""
    deadline = time.monotonic() + timeout
    while not done(read_received(out)) and time.monotonic() < deadline:
        time.sleep(0.02)


def test_every_command_of_a_performer_run_arrives_in_each_form(
    tmp_path: Path, procs: Processes, zenoh_router: str
) -> None:
    profile_path, profile = unlimited_profile(tmp_path)
    performer, robot = graphs(tmp_path, profile_path)
    out = tmp_path / "received.jsonl"
    peer = subscriber(TOPICS, out)
    try:
        robot_proc = start_robot(procs, zenoh_router, robot)
        chain = start_performer(procs, zenoh_router, performer, "--max-frames", str(FRAMES))
        assert chain.wait(180) == 0, procs.log("performer")[-3000:]
        robot_proc.send_signal(signal.SIGTERM)
        assert robot_proc.wait(30) == 0, procs.log("robot")[-3000:]
        count = len(read_record(tmp_path / "commands.jsonl"))
        settle(out, lambda got: all(len(on(topic, got)) >= count for topic in TOPICS))
    finally:
        peer.stop()
    record = read_record(tmp_path / "commands.jsonl")
    received = read_received(out)
    from_frames = [line for line in record if line.frame is not None]
    assert len(from_frames) >= FRAMES * 0.9 and sum(line.face for line in from_frames) > 100
    names = [spec.name for spec in profile.servos]
    neutral = [spec.angle.radians(spec.neutral_us) for spec in profile.servos]
    for topic in ("/facesynth/joint_commands", "/head/trajectory"):
        messages = on(topic, received)
        by_stamp = {m.stamp_ns: m for m in messages}
        assert len(by_stamp) == len(messages), f"{topic}: two messages with one stamp"
        for line in from_frames:
            message = by_stamp.get(line.t_capture_ns)
            assert message is not None, f"{topic}: frame {line.frame}'s command never arrived"
            assert message.names == names
            assert close(message.positions, radians(profile, line)), (topic, line.frame)
        assert close(messages[-1].positions, neutral), f"{topic}: the last command is not neutral"
        assert len(messages) == len(record), f"{topic}: {len(messages)} of {len(record)} commands"
    arrays = [m.positions for m in on("/head/commands", received)]
    assert len(arrays) == len(record)
    wanted = [radians(profile, line) for line in from_frames]
    at = 0
    for values in arrays:  # the frames' commands, in order, among the controller's own moves
        if at < len(wanted) and close(values, wanted[at]):
            at += 1
    assert at == len(wanted), f"only {at} of {len(wanted)} commands in order on the array topic"
    assert close(arrays[-1], neutral)
    jaw = profile.servos.index(profile.servo("jaw"))
    assert any(abs(m.positions[jaw]) > 0.05 for m in on("/head/trajectory", received))
    assert all(-math.pi / 4 - 1e-9 <= m.positions[jaw] <= math.pi / 4 + 1e-9 for m in received)


def test_a_killed_subscriber_never_stalls_the_chain(
    tmp_path: Path, procs: Processes, zenoh_router: str
) -> None:
    profile_path, _ = unlimited_profile(tmp_path)
    performer, robot = graphs(tmp_path, profile_path)
    out = tmp_path / "received.jsonl"
    peer = subscriber(TOPICS, out)
    try:
        start_robot(procs, zenoh_router, robot)
        chain = start_performer(procs, zenoh_router, performer, "--max-frames", str(FRAMES))
        deadline = time.monotonic() + 60
        while len(read_received(out)) < 60:
            assert time.monotonic() < deadline and chain.poll() is None, procs.log("performer")
            time.sleep(0.05)
        peer.kill()
        killed_at = len(read_received(out))
        assert chain.wait(180) == 0, procs.log("performer")[-3000:]
    finally:
        peer.kill()
    record = read_record(tmp_path / "commands.jsonl")
    assert sum(line.frame is not None for line in record) >= FRAMES * 0.9
    assert killed_at < 3 * sum(line.frame is not None for line in record) / 2  # it died early
    assert "Traceback" not in procs.log("robot")


def test_a_terminated_facesynth_leaves_neutral_last(
    tmp_path: Path, procs: Processes, zenoh_router: str
) -> None:
    profile_path, profile = unlimited_profile(tmp_path)
    performer, robot = graphs(tmp_path, profile_path, video_loop=True)
    neutral = [spec.angle.radians(spec.neutral_us) for spec in profile.servos]
    out = tmp_path / "received.jsonl"
    peer = subscriber(TOPICS, out)
    try:
        robot_proc = start_robot(procs, zenoh_router, robot)
        chain = start_performer(procs, zenoh_router, performer)
        deadline = time.monotonic() + 60
        while sum(r.topic == "/facesynth/joint_commands" for r in read_received(out)) < 60:
            assert time.monotonic() < deadline and chain.poll() is None, procs.log("performer")
            time.sleep(0.05)
        moved = [r for r in read_received(out) if r.topic == "/facesynth/joint_commands"]
        robot_proc.send_signal(signal.SIGTERM)
        assert robot_proc.wait(30) == 0, procs.log("robot")[-3000:]
        settle(out, lambda got: all(close(last(on(t, got)), neutral) for t in TOPICS))
    finally:
        peer.stop()
    assert any(not close(m.positions, neutral) for m in moved), "the face never moved"
    received = read_received(out)
    for topic in TOPICS:
        assert close(on(topic, received)[-1].positions, neutral), f"{topic}: not neutral last"
