"""services.control.drivers.serial_link: backoff, state lines, port checks, and the link over
TCP (socket://, and rfc2217:// through pyserial's own RFC 2217 server side) with reconnects."""

from __future__ import annotations

import asyncio
import logging
from pathlib import Path

import pytest
from fake_devices.network import NetworkPort
from fake_devices.ssc32 import FakeSSC32

from facesynth.runtime.profiles import load_profile
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.base import DeviceUnavailable, DriverConfigError
from facesynth.services.control.drivers.serial_link import (
    Backoff,
    LinkState,
    SerialLink,
    check_port,
)
from facesynth.services.control.drivers.ssc32 import SSC32Config, SSC32Driver

INFO = CommandInfo(frame=1, t_capture_ns=None, face=True)


def test_backoff_doubles_up_to_its_cap_and_resets() -> None:
    backoff = Backoff(first=0.1, cap=1.0)
    assert [backoff.next() for _ in range(6)] == pytest.approx([0.1, 0.2, 0.4, 0.8, 1.0, 1.0])
    backoff.reset()
    assert backoff.next() == 0.1
    with pytest.raises(ValueError):
        Backoff(first=2, cap=1)


def test_state_lines() -> None:
    state = LinkState("/dev/ttyACM0")
    assert state.describe() == "disconnected from /dev/ttyACM0 (connecting), 0 writes dropped"
    state.failed_attempts, state.last_error, state.writes_dropped = 3, "cannot open it: gone", 7
    assert state.describe() == (
        "disconnected from /dev/ttyACM0 (3 attempts; last: cannot open it: gone), 7 writes dropped"
    )
    state.connected, state.connects = True, 2
    assert state.describe() == "connected to /dev/ttyACM0, reconnected 1x"


@pytest.mark.parametrize(
    ("port", "message"),
    [
        ("", "the port is empty"),
        ("socket://localhost", "expected socket://HOST:PORT"),
        ("rfc2217://:7000", "expected rfc2217://HOST:PORT"),
        ("socket://host:99999", "expected socket://HOST:PORT"),
        ("spy:///dev/ttyUSB0", "unknown URL scheme 'spy'"),
    ],
)
def test_ports_that_can_never_work_are_config_errors(port: str, message: str) -> None:
    with pytest.raises(DriverConfigError, match=message):
        check_port(port)


@pytest.mark.parametrize(
    "port", ["/dev/ttyACM0", "COM3", "socket://10.0.0.2:4000", "rfc2217://[::1]:2217"]
)
def test_ports_that_may_work(port: str) -> None:
    check_port(port)


async def test_a_port_that_cannot_be_opened(tmp_path: Path) -> None:
    async def nothing(link: SerialLink) -> None:
        raise AssertionError("no handshake without a port")

    log = logging.getLogger("test")
    link = SerialLink(str(tmp_path / "none"), 115200, handshake=nothing, on_bytes=print, log=log)
    with pytest.raises(DeviceUnavailable, match="cannot open it: No such file or directory"):
        await link.open(retry=False)
    await link.open(retry=True)  # the service's way: keep trying in the background
    assert link.retrying and not link.connected
    assert link.write(b"x") is False and link.state.writes_dropped == 1
    await asyncio.sleep(0.35)
    assert link.state.failed_attempts >= 2
    await link.close()


async def test_a_second_opener_of_a_device_path_is_refused(tmp_path: Path) -> None:
    device = FakeSSC32(tmp_path / "ttySSC32")
    device.plug()
    profile = load_profile("paper16")
    first = SSC32Driver(SSC32Config(port=str(device.link)), profile)
    second = SSC32Driver(SSC32Config(port=str(device.link)), profile)
    try:
        await first.connect_once()
        with pytest.raises(DeviceUnavailable, match="in use by another program"):
            await second.connect_once()
    finally:
        await first.close()
        await second.close()
        device.close()


@pytest.mark.filterwarnings("ignore:set(Daemon|Name)\\(\\) is deprecated:DeprecationWarning")
@pytest.mark.parametrize("rfc2217", [False, True], ids=["socket", "rfc2217"])
async def test_a_board_on_the_network_reconnects(rfc2217: bool, tmp_path: Path) -> None:
    device = FakeSSC32(tmp_path / "unused")
    network = NetworkPort(device, rfc2217=rfc2217)
    driver = SSC32Driver(SSC32Config(port=network.url), load_profile("paper16"))
    try:
        await driver.connect()
        assert driver.version == "SSC32-V2.50USB"
        await driver.send({"jaw": 1800.0}, INFO)
        await device.until(lambda: device.widths.get(11) == 1800)
        network.unplug()  # the TCP link drops, and the server is gone for a while
        for _ in range(10):
            await driver.send({"jaw": 1700.0}, INFO)
            await asyncio.sleep(0.05)
        assert "disconnected" in driver.state()
        network.plug()
        for _ in range(100):
            if driver.link.connected:
                break
            await asyncio.sleep(0.05)
        assert driver.link.connected and network.connections == 2
        await asyncio.sleep(0.1)
        with device.lock:
            assert device.widths[11] == 1700  # the pose held while away came back
    finally:
        await driver.close()
        network.close()
