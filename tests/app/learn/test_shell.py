"""The babbling shell on an in-memory bus: the real control interface (record driver) and
recorder, a simulated face that answers the servo states; the session file, resumed."""

from __future__ import annotations

import asyncio
import io
import json
from pathlib import Path
from typing import Any

import pytest

from facesynth.app.learn.core import BabbleOptions, Babbler, Budget
from facesynth.app.learn.plan import Plan, PlanOptions
from facesynth.app.learn.progress import Progress
from facesynth.app.learn.session import SessionFile, babble_set, metadata, read_session
from facesynth.app.learn.settle import SettleOptions
from facesynth.app.learn.shell import RECORD_KEYS, BabbleShell, LearnRunError, babble
from facesynth.app.wiring import StageParts
from facesynth.runtime.bus.memory import MemoryNetwork
from facesynth.runtime.profiles import Profile, load_profile
from facesynth.runtime.service import ServiceContext
from facesynth.schemas.messages import Features, ServoCommands
from facesynth.services.control.drivers.record import RecordConfig, RecordDriver
from facesynth.services.control.service import ControlService

RIG = "self"


def _face_of(positions: dict[str, float], neutral: dict[str, float]) -> dict[str, float]:
    return {f"f_{name}": (value - neutral[name]) / 1000 for name, value in positions.items()}


async def _idle(ctx: ServiceContext) -> None:
    ctx.ready()
    await asyncio.Event().wait()


def _face(profile: Profile, hidden: asyncio.Event) -> Any:
    """A camera, tracker and features node in one: the face follows the reported servos."""

    async def serve(ctx: ServiceContext) -> None:
        states = ctx.subscribe("servo_state", 1, ServoCommands)
        ctx.ready()
        neutral = profile.neutral_positions()
        positions = dict(neutral)
        seq = 0
        while True:
            while (sample := states.receive_nowait()) is not None:
                positions = dict(sample.message.positions)
            seq += 1
            now = ctx.clock.time_ns()
            face = not hidden.is_set()
            raw = _face_of(positions, neutral) if face else {}
            ctx.publish(
                "features",
                Features(
                    seq=seq,
                    t_capture_ns=now,
                    t_media_ns=seq,
                    face=face,
                    neutral_ready=face,
                    raw=raw,
                ),
            )
            await asyncio.sleep(0.02)

    return serve


def _parts(profile: Profile, tmp: Path, hidden: asyncio.Event) -> dict[str, StageParts]:
    driver = RecordDriver(RecordConfig(out=str(tmp / "commands.jsonl")), profile)
    control = ControlService(profile, driver)
    return {
        "sensor": StageParts("sensor", "sensor", _idle),
        "points": StageParts("points", "points", _idle),
        "features": StageParts("features", "features", _face(profile, hidden)),
        "control": StageParts("control", "control", control.serve, control),
    }


def _shell(profile: Profile, start: int, poses: int, out: io.StringIO) -> BabbleShell:
    options = BabbleOptions(
        settle=SettleOptions(frames=2, min_wait_s=0.05, max_wait_s=1.0, reach_timeout_s=3.0),
        pace=1.0,
        hold_s=0.1,
    )
    plan = Plan(len(profile.servos), PlanOptions(seed=4, sweep_steps=1, neutral_every=5))
    babbler = Babbler(profile, plan, start=start, budget=Budget(poses=poses), options=options)
    progress = Progress(out, first=start, total=poses, started_s=0.0, tty=False)
    return BabbleShell(babbler, seed=4, progress=progress, on_neutral=lambda: None)


async def _run(tmp: Path, poses: int, hidden: asyncio.Event | None = None) -> Any:
    profile = load_profile("paper16")
    path = tmp / "s.mcap"
    resume = read_session(path) if path.exists() else None
    start = resume.next_pose if resume is not None else 0
    shell = _shell(profile, start, poses, io.StringIO())
    session = SessionFile(path, metadata(RIG, profile, 4, RECORD_KEYS), resume)
    bus = MemoryNetwork().bus()
    parts = _parts(profile, tmp, hidden or asyncio.Event())
    return await babble(bus, RIG, parts, shell, session, frame_every=0)


async def test_a_run_records_each_settled_pose_and_a_second_one_resumes(tmp_path: Path) -> None:
    result = await _run(tmp_path, 4)
    assert (result.taken, result.next_pose, result.interrupted) == (4, 4, False)
    session = read_session(tmp_path / "s.mcap")
    assert [s.seq for s in session.samples] == [0, 1, 2, 3]
    assert [s.kind for s in session.samples] == ["neutral", "sweep", "sweep", "sweep"]
    profile = load_profile("paper16")
    neutral = profile.neutral_positions()
    for sample in session.samples:
        assert sample.profile == "paper16" and sample.seed == 4 and sample.frames == 2
        for name, value in sample.commanded.items():
            assert sample.reported[name] == pytest.approx(value, abs=10)
            # the face the "camera" saw is the pose's (the servos may still creep the last µs)
            assert sample.features[f"f_{name}"] == pytest.approx(
                (value - neutral[name]) / 1e3, abs=0.011
            )
    # the commands went through the control interface: within limits, back at neutral
    lines = [json.loads(line) for line in (tmp_path / "commands.jsonl").read_text().splitlines()]
    servos = [line["servos"] for line in lines if "servos" in line]
    assert servos[-1] == neutral
    result = await _run(tmp_path, 7)
    assert (result.taken, result.next_pose) == (3, 7)
    session = read_session(tmp_path / "s.mcap")
    assert [s.seq for s in session.samples] == list(range(7))
    assert not (tmp_path / "s.mcap.resume").exists()
    data = babble_set(session.samples, profile)
    assert data.commands.shape == (7, 16) and data.faces.shape == (7, 16)
    assert data.kinds[0] == "neutral"


async def test_servos_that_do_not_follow_end_the_run_with_a_clear_error(tmp_path: Path) -> None:
    profile = load_profile("paper16")
    other = load_profile("head16")
    shell = _shell(profile, 0, 3, io.StringIO())
    shell.babbler.options = BabbleOptions(settle=SettleOptions(reach_timeout_s=0.5))
    session = SessionFile(tmp_path / "s.mcap", metadata(RIG, profile, 4, RECORD_KEYS), None)
    parts = _parts(profile, tmp_path, asyncio.Event())
    control = ControlService(other, RecordDriver(RecordConfig(out=str(tmp_path / "c")), other))
    parts["control"] = StageParts("control", "control", control.serve, control)
    with pytest.raises(LearnRunError, match="does the control interface run profile 'paper16'"):
        await babble(MemoryNetwork().bus(), RIG, parts, shell, session, frame_every=0)
    assert read_session(tmp_path / "s.mcap").samples == []  # the file is complete and readable


async def test_a_camera_that_sees_no_face_is_said_and_a_stop_still_ends_at_neutral(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    monkeypatch.setattr("facesynth.app.learn.shell.NO_FACE_NOTICE_S", 0.3)
    hidden = asyncio.Event()
    hidden.set()
    profile = load_profile("paper16")
    shell = _shell(profile, 0, 5, io.StringIO())
    session = SessionFile(tmp_path / "s.mcap", metadata(RIG, profile, 4, RECORD_KEYS), None)
    parts = _parts(profile, tmp_path, hidden)
    asyncio.get_running_loop().call_later(1.5, shell.babbler.stop)
    result = await babble(MemoryNetwork().bus(), RIG, parts, shell, session, frame_every=0)
    assert result.taken == 0 and shell.babbler.done
    assert "no face in the camera's view" in caplog.text
    assert read_session(tmp_path / "s.mcap").samples == []
