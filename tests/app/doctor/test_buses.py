"""``facesynth doctor`` lists what answers on a control driver's own bus (``found``): here the
PCA9685 on its I2C bus (the register model behind smbus2's interface), read only; a bus that
is not there, and a device that cannot serve the profile, are lines to fix."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fake_devices.pca9685 import FakeI2CAdapter, FakePCA9685
from pca9685_model_driver import ModelConfig, model_driver

from facesynth.app.cli import main
from facesynth.app.doctor.buses import bus_findings, lists_devices
from facesynth.app.doctor.report import Finding, Status
from facesynth.services.control.drivers.base import FoundDevice
from facesynth.services.control.drivers.pca9685 import PCA9685Config, PCA9685Driver
from facesynth.services.control.drivers.record import RecordConfig
from facesynth.services.control.drivers.registry import DRIVERS

QUIET = ["--listen", "tcp/127.0.0.1:0", "--log-level", "WARNING"]


@pytest.fixture
def chip(tmp_path: Path) -> Iterator[tuple[FakePCA9685, str]]:
    """A PCA9685 model on ``tmp_path/i2c-1``, reachable as driver ``pca9685-model``."""
    chip = FakePCA9685()
    adapter = FakeI2CAdapter(tmp_path / "i2c-1", chip)
    with model_driver(adapter):
        yield chip, str(adapter.path)


def lines(findings: list[Finding]) -> list[str]:
    return [" ".join(f.line().split()) for f in findings]


def test_the_board_on_the_bus_is_listed_read_only(chip: tuple[FakePCA9685, str]) -> None:
    model, bus = chip
    findings = bus_findings([("control", "paper16", ModelConfig(bus=bus))])
    assert lines(findings) == [
        "ok bus control node control (pca9685-model) 0x40: PCA9685 (MODE1 0x11, asleep, "
        "PRE_SCALE 30: 196.888 Hz) (for 16 servos on channels 0..15)"
    ]
    assert all(not w.data for w in model.writes)  # only register pointers for reads


def test_a_bus_that_is_not_there_is_a_line_to_fix(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    bus = str(tmp_path / "i2c-7")
    assert main(["doctor", "--driver", "pca9685", "--i2c-bus", bus, *QUIET]) == 2
    out = [" ".join(line.split()) for line in capsys.readouterr().out.splitlines()]
    fixes = [line for line in out if line.startswith("fix bus")]
    assert fixes == [
        f"fix bus control node control (pca9685): {bus}: cannot open it: No such file or "
        "directory: check the bus's wiring and power, and the driver's options (its port or "
        "bus, baud rate or address); stop the control service first (it holds the bus)"
    ]


def test_a_device_of_another_model_is_a_line_to_fix() -> None:
    class Found(PCA9685Driver):
        async def found(self) -> list[FoundDevice]:
            return [
                FoundDevice("id 1", "XM430-W350", servo="jaw"),
                FoundDevice("id 2", "XL320", servo="brow", problem="the profile expects XL430"),
                FoundDevice("id 9", "XL430-W250"),
            ]

    class FoundConfig(PCA9685Config, tag="found-test", tag_field="driver"):
        pass

    async def no_bus(self: Any, *, query_only: bool = False) -> None:
        self._start()

    Found.connect_once = no_bus  # type: ignore[method-assign]
    DRIVERS.register(FoundConfig)(Found)
    try:
        findings = bus_findings([("control", "paper16", FoundConfig())])
    finally:
        DRIVERS.unregister("found-test")
    assert [f.status for f in findings] == [Status.OK, Status.FIX, Status.INFO]
    assert "XL320 (for brow): the profile expects XL430" in findings[1].text


def test_drivers_without_a_bus_list_nothing() -> None:
    assert not lists_devices(RecordConfig(out="x.jsonl")) and not lists_devices(None)
    assert bus_findings([("control", "paper16", RecordConfig(out="x.jsonl"))]) == []
