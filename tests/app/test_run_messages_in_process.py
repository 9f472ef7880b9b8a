"""``facesynth run``: stages in one process hand each other the message objects themselves
(``Bus.publish_message``), and nothing else changes: the commands are those of the bytes path,
no consumer changes a shared message, and an observer in another Zenoh session still gets
every message of every stage."""

from __future__ import annotations

import asyncio
from collections import Counter
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

import pytest
from patient_profiles import patient_profile

import facesynth.app.engine.chain_run as chain_run
from facesynth.app.cli import main
from facesynth.app.data import sample_openface_csv
from facesynth.runtime import codec, keys
from facesynth.runtime.bus.base import Bus, Subscription
from facesynth.runtime.bus.zenoh_bus import ZenohBus, ZenohOptions, router_locators
from facesynth.schemas.messages import Features, Frame, Points, ServoCommands
from facesynth.services.control.drivers.record import read_record

FRAMES = 60


def run_csv(out: Path, *, fast: bool = True) -> None:
    """``facesynth run --fast`` (``fast=False``: in real time) on the bundled OpenFace CSV,
    commands recorded to ``out``, onto paper16 with commands aged up to 5 s (on a loaded machine
    a stall of 0.25 s would make C drop a command as stale, as it should, and the runs would
    differ by it)."""
    profile = patient_profile(out.with_name("paper16-patient.toml"))
    argv = ["run", *(["--fast"] if fast else []), "--openface-csv", str(sample_openface_csv())]
    argv += ["--out", str(out)]
    argv += ["--profile", str(profile), "--max-frames", str(FRAMES)]
    assert main([*argv, "--listen", "tcp/127.0.0.1:0"]) == 0


def stage_of(key: str) -> str | None:
    """The stage of a data key (``facesynth/<rig>/<stage>[/<robot>]``), else ``None``."""
    parts = key.split("/")
    return parts[2] if len(parts) >= 3 and parts[2] in keys.STAGES else None


def commands(path: Path) -> list[tuple[int | None, dict[str, float]]]:
    return [(line.frame, line.servos) for line in read_record(path) if line.frame is not None]


def around_chain(
    monkeypatch: pytest.MonkeyPatch,
    before: Callable[[Bus, str], Awaitable[Any]],
    after: Callable[[Any], Awaitable[None]],
) -> None:
    """Run ``before(bus, rig)`` on ``run``'s bus before its chain starts, ``after`` once it
    drained (with what ``before`` returned)."""
    real = chain_run.run_chain

    async def wrapped(bus: Bus, rig: str, parts: Any, **options: Any) -> Any:
        attached = await before(bus, rig)
        try:
            return await real(bus, rig, parts, **options)
        finally:
            await after(attached)

    monkeypatch.setattr(chain_run, "run_chain", wrapped)


class Witness:
    """Takes every stage message of the rig as the object the stages share, with its bytes
    as they were when it was published, to compare with its bytes after the run."""

    def __init__(self, bus: Bus, rig: str) -> None:
        self.seen: list[tuple[str, Any, bytes]] = []
        self.subscription: Subscription = bus.subscribe_queued(f"{keys.PREFIX}/{rig}/**", 100_000)
        self.subscription.guard(10**9, None, None, lambda message: (message, codec.encode(message)))

    def drain(self) -> None:
        while (sample := self.subscription.receive_nowait()) is not None:
            if sample.parcel is not None:  # an object of this process (not a bytes stream)
                message, encoded = sample.message
                self.seen.append((sample.key, message, encoded))

    def changed(self) -> list[str]:
        """Keys of the messages whose bytes differ now from when they were published."""
        self.drain()
        return [key for key, message, encoded in self.seen if codec.encode(message) != encoded]

    def stages(self) -> Counter[str | None]:
        return Counter(stage_of(key) for key, _, _ in self.seen)


def test_run_commands_are_those_of_the_bytes_path(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    run_csv(tmp_path / "objects.jsonl")

    def as_bytes(self: ZenohBus, key: str, message: Any, encode: Callable[[Any], bytes]) -> None:
        self.publish(key, encode(message))  # every message encoded, decoded by each reader

    monkeypatch.setattr(ZenohBus, "publish_message", as_bytes)
    run_csv(tmp_path / "bytes.jsonl")
    by_object, by_bytes = commands(tmp_path / "objects.jsonl"), commands(tmp_path / "bytes.jsonl")
    assert len(by_object) == FRAMES
    assert by_object == by_bytes


def _witnessed_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, consumer: Callable[[Bus, str], Any] | None
) -> Witness:
    witnesses: list[Witness] = []

    async def before(bus: Bus, rig: str) -> Any:
        witnesses.append(Witness(bus, rig))
        return asyncio.create_task(consumer(bus, rig)) if consumer is not None else None

    async def after(task: Any) -> None:
        witnesses[0].drain()
        if task is not None:
            task.cancel()

    around_chain(monkeypatch, before, after)
    run_csv(tmp_path / "commands.jsonl")
    return witnesses[0]


def test_no_stage_changes_a_message_it_shares(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    witness = _witnessed_run(tmp_path, monkeypatch, None)
    stages = witness.stages()
    for stage in ("input", "points", "features", "servo_commands"):
        assert stages[stage] == FRAMES, stages
    assert stages["servo_state"] >= FRAMES
    assert witness.changed() == []


def test_the_witness_sees_a_consumer_change_a_shared_message(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The check above can fail: a consumer changing a command's table in place is caught.
    async def meddler(bus: Bus, rig: str) -> None:
        subscription = bus.subscribe_queued(keys.stage_key(rig, "servo_commands"), 64)
        subscription.guard(10**6, None, None, lambda message: message)
        async for sample in subscription:
            sample.message.positions["jaw"] = -1.0

    witness = _witnessed_run(tmp_path, monkeypatch, meddler)
    changed = witness.changed()
    assert changed and {stage_of(key) for key in changed} == {"servo_commands"}


def test_an_observer_in_another_session_gets_every_message(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # As `facesynth record` or `facesynth status` would: a client of run's embedded router.
    got: dict[str, list[Any]] = {}

    async def before(bus: Bus, rig: str) -> tuple[ZenohBus, Subscription]:
        assert isinstance(bus, ZenohBus)
        locators = await asyncio.to_thread(router_locators, bus.session)
        observer = await asyncio.to_thread(
            ZenohBus.open, ZenohOptions(mode="client", connect=locators[:1])
        )
        subscription = observer.subscribe_queued(f"{keys.PREFIX}/{rig}/**", 100_000)
        await asyncio.sleep(0.5)  # the subscriber is known to the router
        return observer, subscription

    async def after(attached: tuple[ZenohBus, Subscription]) -> None:
        observer, subscription = attached
        await asyncio.sleep(0.5)  # the last messages on their way
        while (sample := subscription.receive_nowait()) is not None:
            assert sample.parcel is None  # bytes, through Zenoh
            stage = stage_of(sample.key)
            if stage is not None:
                got.setdefault(stage, []).append(sample.payload)
        await observer.close()

    around_chain(monkeypatch, before, after)
    # In real time (2 s): every publication is sent with Zenoh's DROP congestion control (a
    # publisher never blocks), so a flood at full speed (--fast: 60 frames in 0.1 s) may shed
    # a message toward another session when the machine starves Zenoh's threads (seen with two
    # test workers and a soak on 2 cores); at the frame rate the link keeps up.
    run_csv(tmp_path / "commands.jsonl", fast=False)
    types = {"input": Frame, "points": Points, "features": Features}
    for stage, kind in {**types, "servo_commands": ServoCommands}.items():
        seqs = [codec.decode(payload, kind).seq for payload in got.get(stage, [])]
        assert seqs == list(range(FRAMES)), stage
    states = [codec.decode(payload, ServoCommands) for payload in got["servo_state"]]
    applied = [state.seq for state in states if state.move == "command"]
    assert applied == list(range(FRAMES))
