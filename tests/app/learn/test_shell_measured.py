"""Measured positions flow on through babbling: the real control interface on an in-memory bus,
with a driver that reads its servos back (a test double: the record driver, plus servos that
move at a finite speed and report where they are). Poses settle on the measured positions,
the log says so, and the session keeps them."""

from __future__ import annotations

import asyncio
import io
import logging
import time
from collections.abc import Mapping
from pathlib import Path

import pytest
from test_shell import RIG, _face, _idle, _shell

from facesynth.app.learn.session import SessionFile, metadata, read_session
from facesynth.app.learn.shell import RECORD_KEYS, babble
from facesynth.app.wiring import StageParts
from facesynth.runtime.bus.memory import MemoryNetwork
from facesynth.runtime.profiles import Profile, load_profile
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.base import ServoReading
from facesynth.services.control.drivers.record import RecordConfig, RecordDriver
from facesynth.services.control.service import ControlService

SPEED_US_S = 3000.0


class ReadBackDriver(RecordDriver):
    """The record driver, and servos that move toward their commands at ``SPEED_US_S``."""

    def __init__(self, config: RecordConfig, profile: Profile) -> None:
        super().__init__(config, profile)
        self.where = profile.neutral_positions()
        self.goal = dict(self.where)
        self.then = time.monotonic()

    async def send(self, positions: Mapping[str, float], info: CommandInfo) -> None:
        self._move()
        await super().send(positions, info)
        self.goal.update(positions)

    def readings(self) -> Mapping[str, ServoReading]:
        self._move()
        return {name: ServoReading(us, load=0.1) for name, us in self.where.items()}

    def _move(self) -> None:
        now = time.monotonic()
        step, self.then = SPEED_US_S * (now - self.then), now
        for name, goal in self.goal.items():
            here = self.where[name]
            self.where[name] = (
                goal if abs(goal - here) <= step else here + step * (goal > here or -1)
            )


async def test_poses_settle_on_the_positions_the_servos_report(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO)
    profile = load_profile("paper16")
    shell = _shell(profile, 0, 4, io.StringIO())
    session = SessionFile(tmp_path / "s.mcap", metadata(RIG, profile, 4, RECORD_KEYS), None)
    driver = ReadBackDriver(RecordConfig(out=str(tmp_path / "commands.jsonl")), profile)
    control = ControlService(profile, driver)
    parts = {
        "sensor": StageParts("sensor", "sensor", _idle),
        "points": StageParts("points", "points", _idle),
        "features": StageParts("features", "features", _face(profile, asyncio.Event())),
        "control": StageParts("control", "control", control.serve, control),
    }
    result = await babble(MemoryNetwork().bus(), RIG, parts, shell, session, frame_every=0)
    assert result.taken == 4 and result.reached == {"measured": 4}
    assert "poses settle on measured positions" in caplog.text
    samples = read_session(tmp_path / "s.mcap").samples
    assert [s.reached for s in samples] == ["measured"] * 4
    for sample in samples:
        assert set(sample.measured) == set(sample.commanded)
        assert all(abs(sample.measured[n] - v) <= 20 for n, v in sample.commanded.items())
