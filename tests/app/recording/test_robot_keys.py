"""A multi-robot rig's keys in recordings (``…/servo_commands/<robot>``,
``…/servo_state/<robot>``): recorded typed like their stage's, exported one robot at a time,
replayed on each robot's own key to its own control interface."""

from __future__ import annotations

import asyncio
import contextlib
import json
import time
from pathlib import Path

import pytest
from session_chain import commands, open_bus

from facesynth.app.cli import main
from facesynth.app.recording.convert import ConvertError, export_csv, export_jsonl
from facesynth.app.recording.layout import Layout
from facesynth.app.recording.reader import Recording
from facesynth.app.recording.recorder import Recorder, RecordOptions
from facesynth.app.recording.replay import Replayer, ReplayOptions
from facesynth.app.recording.writer import SessionWriter
from facesynth.runtime import codec, keys
from facesynth.runtime.profiles import load_profile
from facesynth.runtime.service import ServiceContext, run_service
from facesynth.schemas.messages import ServoCommands
from facesynth.services.control.drivers.record import RecordConfig, RecordDriver, read_record
from facesynth.services.control.service import ControlService

#: Each robot's jaw, far apart so that whose commands a file holds shows.
JAW = {"a": 1300.0, "b": 1700.0}


def _command(seq: int, jaw: float) -> ServoCommands:
    return ServoCommands(
        seq=seq,
        t_capture_ns=time.time_ns(),
        t_media_ns=seq * 33_333_333,
        face=True,
        profile="paper16",
        positions={"jaw": jaw},
    )


def _write(path: Path, stage: keys.Stage, frames: int = 5) -> None:
    """A recording of rig ``lab`` with robots a's and b's ``stage``, interleaved."""
    writer = SessionWriter(path, metadata={"rig": "lab"}, fsync=False)
    layout = Layout()
    try:
        for seq in range(frames):
            for robot, jaw in JAW.items():
                key = keys.stage_key("lab", stage, robot)
                payload = codec.encode(_command(seq, jaw + seq))
                log_time = 1_700_000_000_000_000_000 + seq * 33_333_333 + len(robot)
                for entry in layout.entries(key, payload, log_time, seq):
                    writer.write(entry)
    finally:
        writer.close()
    assert not layout.raw


async def test_the_recorder_keeps_each_robots_commands_and_state_typed(
    tmp_path: Path, rig: str
) -> None:
    session = tmp_path / "robots.mcap"
    writer = SessionWriter(session, metadata={"rig": rig}, fsync=False)
    recorder = Recorder(writer, RecordOptions(keys=["servo_commands", "servo_state"]))
    stray = keys.stage_key(rig, "servo_commands", "a") + "/more"  # five parts: no robot's key
    sent: dict[str, list[ServoCommands]] = {}
    bus = await open_bus()
    try:
        task = asyncio.create_task(
            run_service(ServiceContext(bus, rig, "record", stats_interval=0.5), recorder.serve)
        )
        await recorder.listening.wait()
        await asyncio.sleep(0.2)  # subscriptions declared
        for robot, jaw in JAW.items():
            for stage in keys.ROBOT_STAGES:
                key = keys.stage_key(rig, stage, robot)
                sent[key] = [_command(seq, jaw + seq) for seq in range(5)]
                for message in sent[key]:
                    bus.publish(key, codec.encode(message))
        bus.publish(stray, codec.encode(_command(0, 1500.0)))
        for _ in range(100):
            if sum(recorder.recorded.values()) == 21:
                break
            await asyncio.sleep(0.05)
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task
    finally:
        await bus.close()
    assert dict(recorder.layout.raw) == {stray: 1}  # kept verbatim, untyped, as before
    with Recording(session) as recording:
        assert recording.stages() == ["servo_commands", "servo_state"]
        assert recording.stage_keys("servo_state") == [
            keys.stage_key(rig, "servo_state", "a"),
            keys.stage_key(rig, "servo_state", "b"),
        ]
        for key, messages in sent.items():
            assert [message for _, message, _ in recording.messages([key])] == messages
        schemas = {
            channel.topic: schema.name
            if (schema := recording.schemas.get(channel.schema_id))
            else ""
            for channel in recording.channels.values()
        }
    assert {schemas["/" + key] for key in sent} == {"facesynth.ServoCommands"}
    assert schemas[f"/{stray}/raw"] == ""


def test_a_recording_of_several_robots_exports_one_robots_commands(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    session = tmp_path / "robots.mcap"
    _write(session, "servo_state")
    with Recording(session) as recording:
        assert recording.stages() == ["servo_state"]
        with pytest.raises(ConvertError, match=r"servo_state of several robots .*--robot NAME"):
            export_jsonl(recording, tmp_path / "both.jsonl")
        with pytest.raises(ConvertError, match="no servo_state of robot 'c'"):
            export_csv(recording, tmp_path / "c.csv", robot="c")
        assert export_csv(recording, tmp_path / "b.csv", robot="b") == 5
    assert not (tmp_path / "both.jsonl").exists() and not (tmp_path / "c.csv").exists()
    rows = (tmp_path / "b.csv").read_text().splitlines()
    assert [row.rsplit(",", 1)[1] for row in rows] == ["jaw", *(f"{1700.0 + s}" for s in range(5))]
    out = tmp_path / "a.jsonl"
    assert main(["convert", str(session), str(out), "--robot", "a"]) == 0
    assert json.loads(capsys.readouterr().out)["messages"] == 5
    lines = read_record(out)
    assert [(line.frame, line.servos) for line in lines] == [
        (seq, {"jaw": 1300.0 + seq}) for seq in range(5)
    ]
    assert main(["convert", str(session), str(tmp_path / "x.jsonl")]) == 2
    assert "facesynth convert: error: " in capsys.readouterr().err


async def test_replay_plays_each_robots_commands_to_its_own_control_interface(
    tmp_path: Path, rig: str
) -> None:
    session = tmp_path / "robots.mcap"
    _write(session, "servo_commands", frames=10)  # recorded on rig lab, replayed on ``rig``
    controls: dict[str, ControlService] = {}
    tasks = []
    bus = await open_bus()
    try:
        for robot in JAW:
            controls[robot] = control = ControlService(
                load_profile("paper16"),
                RecordDriver(RecordConfig(out=str(tmp_path / f"{robot}.jsonl"))),
                motion_time="media",
                watchdog_s=5.0,
            )
            ctx = ServiceContext(
                bus, rig, "control", instance=f"c-{robot}", stats_interval=0.5, robot=robot
            )
            tasks.append(asyncio.create_task(run_service(ctx, control.serve)))
        with Recording(session) as recording:
            options = ReplayOptions(stage="servo_commands", fast=True, wait_for=["control"])
            replayer = Replayer(recording, options)
            ctx = ServiceContext(bus, rig, "replay", stats_interval=0.5)
            assert replayer.targets(ctx) == {
                keys.stage_key("lab", "servo_commands", robot): keys.stage_key(
                    rig, "servo_commands", robot
                )
                for robot in JAW
            }
            await run_service(ctx, replayer.serve)
        for _ in range(100):
            if all(control.last_frame >= 9 for control in controls.values()):
                break
            await asyncio.sleep(0.05)
    finally:
        for task in tasks:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
        await bus.close()
    assert replayer.published == 20 and replayer.stalls == 0
    played = {robot: commands(tmp_path / f"{robot}.jsonl") for robot in JAW}
    for robot in JAW:
        assert [frame for frame, _ in played[robot]] == list(range(10)), robot
    # each robot took its own commands only (C limits the jaw's speed from neutral, 1500)
    assert all(servos["jaw"] < 1500 for _, servos in played["a"])
    assert all(servos["jaw"] > 1500 for _, servos in played["b"])
