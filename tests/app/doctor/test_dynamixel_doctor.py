"""``facesynth doctor`` on a Dynamixel bus (the emulated Protocol 2.0 bus on a pty): every id
and model found, which servo of the profile each serves, the profile's servos that do not
answer or are another model, and ids on the bus no servo uses; nothing is written."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from fake_devices.dynamixel import FakeDynamixelBus

from facesynth.app.cli import main
from facesynth.app.doctor.buses import bus_findings, lists_devices
from facesynth.services.control.drivers.dynamixel import DynamixelConfig

QUIET = ["--listen", "tcp/127.0.0.1:0", "--log-level", "WARNING"]
PROFILE = """name = "bus3"
[bus]
baud = 1000000
[[servos]]
name = "jaw"
channel = 0
model = "XL430-W250"
min_us = 1000
neutral_us = 1500
max_us = 2000
[[servos]]
name = "brow"
channel = 1
model = "XM430-W350"
min_us = 1000
neutral_us = 1500
max_us = 2000
[[servos]]
name = "lid"
channel = 2
min_us = 1000
neutral_us = 1500
max_us = 2000
"""


@pytest.fixture
def bus(tmp_path: Path) -> Iterator[tuple[FakeDynamixelBus, str]]:
    """Ids 1 and 2 (XL430-W250) and 7 (no servo of the profile); id 3 is missing."""
    device = FakeDynamixelBus(tmp_path / "ttyDXL", [1, 2, 7])
    device.plug()
    profile = tmp_path / "bus3.toml"
    profile.write_text(PROFILE)
    try:
        yield device, str(profile)
    finally:
        device.close()


def test_ids_and_models_found_are_listed_read_only(bus: tuple[FakeDynamixelBus, str]) -> None:
    device, profile = bus
    config = DynamixelConfig(port=str(device.link))
    assert lists_devices(config)
    findings = bus_findings([("control", profile, config)])
    lines = [" ".join(f.line().split()) for f in findings]
    node = "control node control (dynamixel)"
    assert lines == [
        f"ok bus {node} id 1: XL430-W250 (for jaw)",
        f"fix bus {node} id 2: XL430-W250 (for brow): servo 'brow' (id 2) is a XL430-W250 "
        "(model number 1060), but profile 'bus3' expects a XM430-W350: check the bus's wiring "
        "and power, and the driver's options (its port or bus, baud rate or address); stop the "
        "control service first (it holds the bus)",
        f"fix bus {node} id 3: no answer (for lid): does not answer at 1000000 baud: check the "
        "bus's wiring and power, and the driver's options (its port or bus, baud rate or "
        "address); stop the control service first (it holds the bus)",
        f"info bus {node} id 7: XL430-W250 (no servo uses it)",
    ]
    writes = [p for p in device.packets if p[1] in (0x03, 0x83)]
    assert writes == []  # pings and reads only: nothing configured, nothing moved
    assert not any(device.torque().values())


def test_doctor_command_lists_the_bus(
    bus: tuple[FakeDynamixelBus, str],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    device, profile = bus
    monkeypatch.chdir(tmp_path)
    argv = ["doctor", "--driver", "dynamixel", "--port", str(device.link), "--profile", profile,
            *QUIET]  # fmt: skip
    main(argv)
    out = [" ".join(line.split()) for line in capsys.readouterr().out.splitlines()]
    assert "ok bus control node control (dynamixel) id 1: XL430-W250 (for jaw)" in out
    assert "info bus control node control (dynamixel) id 7: XL430-W250 (no servo uses it)" in out
