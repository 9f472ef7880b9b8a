"""The ``ssc32`` driver against a fake SSC-32U on a pty: group moves with S and T, the version
check, status, slow baud rates, a board that stops answering."""

from __future__ import annotations

import asyncio
import logging
from pathlib import Path

import pytest
from fake_devices.ssc32 import FakeSSC32
from profile_files import write_profile

from facesynth.runtime.profiles import load_profile
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.ssc32 import SSC32Config, SSC32Driver
from facesynth.services.control.drivers.ssc32 import driver as ssc32_driver

INFO = CommandInfo(frame=1, t_capture_ns=None, face=True)


async def test_each_pose_is_one_group_move_with_speeds_and_time(ssc32: FakeSSC32) -> None:
    profile = load_profile("paper16")
    driver = SSC32Driver(SSC32Config(port=str(ssc32.link), move_time_ms=40), profile)
    await driver.connect()
    try:
        await driver.send({s.name: 1100.0 + 40 * s.channel for s in profile.servos}, INFO)
        await ssc32.until(lambda: ssc32.widths.get(15) == 1700)
        move = ssc32.moves[-1]
        assert move.widths == {ch: 1100 + 40 * ch for ch in range(16)}
        assert move.speeds[11] == 2500 and move.speeds[3] == 6000 and move.time_ms == 40
        assert ssc32.queries[0] == "VER" and ssc32.ignored == []
    finally:
        await driver.close()


async def test_without_speed_limits_there_is_no_s(ssc32: FakeSSC32) -> None:
    driver = SSC32Driver(
        SSC32Config(port=str(ssc32.link), speed_limits=False), load_profile("paper16")
    )
    await driver.connect()
    try:
        await driver.send({"jaw": 1234.0}, INFO)
        await ssc32.until(lambda: ssc32.widths.get(11) == 1234)
        assert ssc32.moves[-1].speeds == {} and ssc32.moves[-1].time_ms is None
    finally:
        await driver.close()


def test_a_slow_baud_rate_is_warned_about(caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.WARNING):
        SSC32Driver(SSC32Config(port="/dev/null", baud=9600), load_profile("paper16"))
    assert "takes 207 ms on the wire at 9600 baud" in caplog.text
    caplog.clear()
    with caplog.at_level(logging.WARNING):
        SSC32Driver(SSC32Config(port="/dev/null"), load_profile("paper16"))
    assert caplog.text == ""


async def test_status_reports_version_and_widths(ssc32: FakeSSC32) -> None:
    with ssc32.lock:
        ssc32.widths[11] = 1730
    driver = SSC32Driver(SSC32Config(port=str(ssc32.link)), load_profile("paper16"))
    await driver.connect_once(query_only=True)
    try:
        status = await driver.device_status()
    finally:
        await driver.close()
    assert status["version"] == "SSC32-V2.50USB" and status["moving"] is False
    assert status["positions_us"]["jaw"] == 1730 and status["positions_us"]["right_eyebrow"] == 0
    assert ssc32.moves == []  # a status does not move anything


async def test_a_board_that_does_not_answer(
    ssc32: FakeSSC32, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(ssc32_driver, "ANSWER_TIMEOUT_S", 0.3)
    monkeypatch.setattr(ssc32_driver, "CHECK_EVERY_S", 0.1)
    monkeypatch.setattr(ssc32_driver, "REPLY_TIMEOUT_S", 0.3)
    answer = ssc32.handle
    ssc32.handle = lambda data: (answer(data), b"")[1]  # type: ignore[method-assign]
    driver = SSC32Driver(SSC32Config(port=str(ssc32.link)), load_profile("paper16"))
    try:
        with pytest.raises(Exception, match=r"no answer from the SSC-32 to VER \(check --baud"):
            await driver.connect_once()
        await driver.close()
        ssc32.handle = answer  # type: ignore[method-assign]
        await driver.connect()
        ssc32.handle = lambda data: (answer(data), b"")[1]  # type: ignore[method-assign]
        for _ in range(40):
            await driver.send({"jaw": 1600.0}, INFO)
            await asyncio.sleep(0.05)
            if driver.link.state.losses:
                break
        assert "no answer to Q" in driver.link.state.last_error
    finally:
        ssc32.handle = answer  # type: ignore[method-assign]
        await driver.close()


async def test_a_profile_with_thirty_two_servos(ssc32: FakeSSC32, tmp_path: Path) -> None:
    servos = [
        {"name": f"s{ch}", "channel": ch, "min_us": 600, "neutral_us": 1500, "max_us": 2400}
        for ch in range(32)
    ]
    profile = load_profile(str(write_profile(tmp_path / "big.toml", servos)))
    driver = SSC32Driver(SSC32Config(port=str(ssc32.link)), profile)
    await driver.connect()
    try:
        await driver.send({f"s{ch}": 700.0 + 50 * ch for ch in range(32)}, INFO)
        await ssc32.until(lambda: ssc32.widths.get(31) == 700 + 50 * 31)
        assert ssc32.moves[-1].widths == {ch: 700 + 50 * ch for ch in range(32)}
    finally:
        await driver.close()
