"""The chain (or its tail) in one process on a real Zenoh router session, as `facesynth run`
runs it, with a recorder or a replay attached: for round-trip tests."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

from facesynth.app.chain import run_chain
from facesynth.app.engine.router import open_embedded
from facesynth.app.recording import RECORDABLE
from facesynth.app.recording.reader import Recording
from facesynth.app.recording.recorder import Recorder, RecordOptions
from facesynth.app.recording.replay import Replayer, ReplayOptions
from facesynth.app.recording.writer import SessionWriter
from facesynth.app.wiring import StageParts
from facesynth.runtime.bus.zenoh_bus import ZenohBus, ZenohOptions
from facesynth.runtime.profiles import load_profile
from facesynth.runtime.service import ServiceContext, run_service
from facesynth.services.control.drivers.record import RecordConfig, RecordDriver, read_record
from facesynth.services.control.service import ControlService
from facesynth.services.features.core import FeatureProcessor
from facesynth.services.features.service import serve_features
from facesynth.services.points.backends import PointsBackend
from facesynth.services.points.service import serve_points
from facesynth.services.sensor.service import SensorOptions, SensorService
from facesynth.services.sensor.sources import FrameSource
from facesynth.services.translator.core import Translator
from facesynth.services.translator.service import serve_translator

Body = Callable[[ServiceContext], Awaitable[Any]]


async def open_bus() -> ZenohBus:
    """A router session on a free loopback port, like `facesynth run`'s embedded one."""
    session, _ = await asyncio.to_thread(
        open_embedded, ["tcp/127.0.0.1:0"], ZenohOptions(mode="router")
    )
    return ZenohBus(session, mode="router")


def stage_bodies(first: str, profile: str, backend: PointsBackend | None) -> dict[str, Body]:
    """Fresh points/features/translator bodies for the stages after ``first``."""
    spec = load_profile(profile)
    bodies: dict[str, Body] = {}
    if first == "input":
        assert backend is not None
        bodies["points"] = lambda ctx: serve_points(ctx, backend, 2)
    if first in ("input", "points"):
        processor = FeatureProcessor(neutral_seconds=spec.neutral_seconds)
        bodies["features"] = lambda ctx: serve_features(ctx, processor, 8)
    if first in ("input", "points", "features"):
        translator = Translator(spec, None)
        bodies["translator"] = lambda ctx: serve_translator(ctx, translator, 8)
    return bodies


def commands(path: Path) -> list[tuple[int | None, dict[str, float]]]:
    """What a record driver wrote for frames (not the neutral poses around them)."""
    return [(line.frame, line.servos) for line in read_record(path) if line.frame is not None]


async def _start_recorder(
    bus: ZenohBus, rig: str, session: Path
) -> tuple[asyncio.Task[Any], Recorder]:
    writer = SessionWriter(session, metadata={"rig": rig}, fsync=False)
    recorder = Recorder(writer, RecordOptions(keys=list(RECORDABLE)))
    ctx = ServiceContext(bus, rig, "record", stats_interval=0.5)
    task = asyncio.create_task(run_service(ctx, recorder.serve))
    await asyncio.sleep(0.2)  # subscriptions declared
    return task, recorder


async def _stop(task: asyncio.Task[Any]) -> None:
    task.cancel()
    with contextlib.suppress(asyncio.CancelledError):
        await task


async def live_run(
    tmp: Path,
    rig: str,
    source: FrameSource,
    backend: PointsBackend,
    *,
    session: Path | None = None,
    profile: str = "paper16",
    max_frames: int | None = None,
) -> list[tuple[int | None, dict[str, float]]]:
    """Run the whole chain (sensor --fast) once; record every key to ``session`` if given."""
    out = tmp / f"live-{rig}.jsonl"
    bus = await open_bus()
    try:
        recording = await _start_recorder(bus, rig, session) if session else None
        # Replays faster than real time into a file: speed limits on the commands' media time;
        # a watchdog that a loaded machine's stall does not fire (its return changes commands).
        control = ControlService(
            load_profile(profile),
            RecordDriver(RecordConfig(out=str(out))),
            motion_time="media",
            watchdog_s=5.0,
        )
        sensor = SensorService(
            source, SensorOptions(fast=True, wait_timeout=10.0, max_frames=max_frames)
        )
        parts = [
            StageParts("sensor", "sensor", sensor.serve, sensor),
            *(
                StageParts(name, name, body)
                for name, body in stage_bodies("input", profile, backend).items()
            ),
            StageParts("control", "control", control.serve, control),
        ]
        result = await run_chain(bus, rig, parts, stats_interval=0.5)
        assert result.frames == result.commands, result
        if recording is not None:
            await asyncio.sleep(0.5)  # the last messages reach the recorder
            await _stop(recording[0])
    finally:
        await bus.close()
    return commands(out)


async def replay_run(
    tmp: Path,
    rig: str,
    session: Path,
    stage: str,
    *,
    backend: PointsBackend | None = None,
    profile: str = "paper16",
    fast: bool = True,
    speed: float = 1.0,
) -> tuple[list[tuple[int | None, dict[str, float]]], Replayer]:
    """Replay ``stage`` of ``session`` into fresh stages after it and a control interface."""
    out = tmp / f"replay-{rig}-{stage}.jsonl"
    bus = await open_bus()
    tasks: list[asyncio.Task[Any]] = []
    try:
        # Replays faster than real time into a file: speed limits on the commands' media time;
        # a watchdog that a loaded machine's stall does not fire (its return changes commands).
        control = ControlService(
            load_profile(profile),
            RecordDriver(RecordConfig(out=str(out))),
            motion_time="media",
            watchdog_s=5.0,
        )
        bodies = {"control": control.serve, **stage_bodies(stage, profile, backend)}
        for name, body in bodies.items():
            ctx = ServiceContext(bus, rig, name, stats_interval=0.5)
            tasks.append(asyncio.create_task(run_service(ctx, body)))
        with Recording(session) as recording:
            options = ReplayOptions(stage=stage, fast=fast, speed=speed, wait_for=list(bodies))
            replayer = Replayer(recording, options)
            ctx = ServiceContext(bus, rig, "replay", stats_interval=0.5)
            await run_service(ctx, replayer.serve)
        for _ in range(100):  # the last command of a timed replay
            if control.last_frame >= replayer.last_seq:
                break
            await asyncio.sleep(0.05)
    finally:
        for task in tasks:
            await _stop(task)
        await bus.close()
    return commands(out), replayer
