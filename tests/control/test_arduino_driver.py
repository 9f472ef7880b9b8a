"""The ``arduino`` driver against the real firmware on the emulated Uno (simavr + PCA9685).

Widths are what the emulated PCA9685 outputs; frames are what the firmware's UART received
(the harness log). Times asserted are emulated; wall-clock timeouts only bound the waits.
"""

from __future__ import annotations

import asyncio
import os
import signal
import statistics
from pathlib import Path

import pytest
from profile_files import write_profile
from uno_rig import UnoRig, near, payload_entries
from waiting import eventually

from facesynth.runtime.profiles import Profile, load_profile
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.arduino import ArduinoConfig, ArduinoDriver
from facesynth.services.control.drivers.arduino import protocol as proto
from facesynth.services.control.drivers.arduino.driver import firmware_limits
from facesynth.services.control.drivers.base import DriverConfigError

pytestmark = pytest.mark.firmware

INFO = CommandInfo(frame=1, t_capture_ns=None, face=True)
SET_ALL = proto.COMMANDS["SET_ALL"].code
SET_SOME = proto.COMMANDS["SET_SOME"].code
SET_LIMITS = proto.COMMANDS["SET_LIMITS"].code


def varied_profile(
    tmp_path: Path, channels: list[int] | None = None, *, rate_limits: bool = True
) -> Profile:
    """Servos with different limits and neutrals (so the firmware's neutral shows they arrived)."""
    servos = []
    for ch in channels if channels is not None else list(range(16)):
        servos.append(
            {
                "name": f"s{ch}",
                "channel": ch,
                "min_us": 900 + 10 * ch,
                "neutral_us": 1400 + 10 * ch,
                "max_us": 2000 + 10 * ch,
                "max_speed": 5000 if rate_limits and ch % 2 == 0 else 0,
            }
        )
    path = write_profile(tmp_path / "varied.toml", servos)
    return load_profile(str(path))


async def connected(rig: UnoRig, profile: Profile, **config: object) -> ArduinoDriver:
    driver = ArduinoDriver(ArduinoConfig(port=str(rig.port), **config), profile)  # type: ignore[arg-type]
    await driver.connect()
    assert driver.link.connected, driver.state()
    return driver


async def hold(
    driver: ArduinoDriver, positions: dict[str, float], rig: UnoRig, want: dict[int, float]
) -> None:
    """Send ``positions`` every 50 ms until the board shows ``want``."""
    for _ in range(200):
        await driver.send(positions, INFO)
        if all(near(rig.widths().get(ch, -1), us) for ch, us in want.items()):
            return
        await asyncio.sleep(0.05)
    raise AssertionError(f"widths {rig.widths()} never reached {want}")


async def test_connect_sends_the_watchdog_and_the_profile_limits(
    uno: UnoRig, tmp_path: Path
) -> None:
    profile = varied_profile(tmp_path)
    driver = await connected(uno, profile, board_watchdog_ms=750)
    try:
        codes = [f.code for f in uno.commands()]
        first_state_change = min(i for i, c in enumerate(codes) if c >= 0x10)
        assert set(codes[:first_state_change]) == {
            proto.COMMANDS["PING"].code,
            proto.COMMANDS["STATUS"].code,
        }
        watchdog = next(f for f in uno.commands() if f.code == proto.COMMANDS["SET_WATCHDOG"].code)
        assert payload_entries(watchdog) == [(750,)]
        limits = [e for f in uno.commands() if f.code == SET_LIMITS for e in payload_entries(f)]
        expected = firmware_limits(profile, driver.map)
        assert limits == [
            (ch, lim.min_us, lim.neutral_us, lim.max_us, lim.max_step_us)
            for ch, lim in sorted(expected.items())
        ]
        assert expected[0] == proto.Limits(900, 1400, 2000, 100)  # 5000 us/s = 100 us per 20 ms
        assert expected[1].max_step_us == 0
        status = await driver.device_status()
        assert "LIMITS_SET" in status["flags"] and status["watchdog_ms"] == 750
        assert status["channels"] == 16 and status["output"] == "PCA9685"
        # The board's neutral is now the profile's.
        await hold(driver, {"s0": 1800.0, "s7": 1100.0}, uno, {0: 1800, 7: 1100})
        await driver.neutral(profile.neutral_positions())
        await uno.settle({ch: 1400 + 10 * ch for ch in range(16)})
        assert proto.COMMANDS["NEUTRAL"].code in [f.code for f in uno.commands()]
    finally:
        await driver.close()


async def test_sixteen_channels_reach_the_commanded_widths(uno: UnoRig) -> None:
    profile = load_profile("paper16")
    driver = await connected(uno, profile)
    try:
        want = {spec.channel: 1010 + 61 * spec.channel for spec in profile.servos}
        await hold(driver, {s.name: float(want[s.channel]) for s in profile.servos}, uno, want)
        assert all(near(uno.widths()[ch], us) for ch, us in want.items())
        assert any(f.code == SET_ALL for f in uno.commands())  # the profile covers every channel
        assert not any(f.code == SET_SOME for f in uno.commands())
    finally:
        await driver.close()


async def test_a_profile_with_some_channels_sends_set_some(uno: UnoRig, tmp_path: Path) -> None:
    profile = varied_profile(tmp_path, [2, 5, 9])
    driver = await connected(uno, profile)
    try:
        await hold(
            driver, {"s2": 1111.0, "s5": 1555.0, "s9": 1999.0}, uno, {2: 1111, 5: 1555, 9: 1999}
        )
        some = [f for f in uno.commands() if f.code == SET_SOME]
        assert some and not any(f.code == SET_ALL for f in uno.commands())
        assert [e[0] for e in payload_entries(some[-1])] == [2, 5, 9]
        assert all(near(uno.widths()[ch], 1500) for ch in (0, 1, 3, 15))  # untouched channels
    finally:
        await driver.close()


async def test_out_of_range_positions_never_reach_the_wire(uno: UnoRig, tmp_path: Path) -> None:
    """Given values outside the limits (the control core would never pass them), the driver
    clamps before encoding: the firmware has nothing left to clamp."""
    profile = varied_profile(tmp_path, [0, 1])
    driver = await connected(uno, profile)
    try:
        await hold(driver, {"s0": 100.0, "s1": 9000.0}, uno, {0: 900, 1: 2010})
        for frame in uno.commands():
            if frame.code == SET_SOME:
                for ch, us in payload_entries(frame):
                    lim = driver.limits[ch]
                    assert lim.min_us <= us <= lim.max_us
        status = await driver.device_status()
        assert status["clamped"] == 0 and driver.clamped == 0
    finally:
        await driver.close()


async def test_pulled_cable_reconnects_and_carries_on(uno: UnoRig) -> None:
    profile = load_profile("paper16")
    driver = await connected(uno, profile)
    try:
        await hold(driver, {"jaw": 1800.0}, uno, {11: 1800})
        assert uno.cable is not None
        uno.cable.unplug()
        for _ in range(10):  # the service keeps sending: nothing raises, writes are dropped
            await driver.send({"jaw": 1200.0}, INFO)
            await asyncio.sleep(0.05)
        assert not driver.link.connected and "disconnected" in driver.state()
        uno.cable.plug()
        await hold(driver, {"jaw": 1300.0}, uno, {11: 1300})
        assert driver.link.state.connects == 2 and driver.link.state.losses == 1
        assert driver.nacks == {}  # the sequence went on from the board's last_seq
        assert len([e for e in uno.board.events("reg") if e[1] == "PRE_SCALE"]) == 1  # no reboot
    finally:
        await driver.close()


async def test_a_board_that_reset_gets_its_limits_again(uno: UnoRig, tmp_path: Path) -> None:
    profile = varied_profile(tmp_path)
    driver = await connected(uno, profile)
    try:
        await hold(driver, {"s3": 1900.0}, uno, {3: 1900})
        uno.restart()  # a brownout: the USB adapter (the cable) stays, the board reboots
        await hold(driver, {"s3": 1700.0}, uno, {3: 1700})
        assert driver.board_resets == 1 and driver.link.state.losses == 0
        # Sent to the new boot once an ACK said its limits were gone: the positions before it
        # may already show (within the firmware's own limits), so the limits are waited for.
        await eventually(lambda: any(f.code == SET_LIMITS for f in uno.commands()))
        await driver.neutral(profile.neutral_positions())
        await uno.settle({ch: 1400 + 10 * ch for ch in range(16)})
    finally:
        await driver.close()


async def test_a_stale_sequence_is_resynchronised(uno: UnoRig) -> None:
    profile = load_profile("paper16")
    driver = await connected(uno, profile)
    try:
        await hold(driver, {"jaw": 1800.0}, uno, {11: 1800})
        assert uno.cable is not None
        # Someone else's command moves the board's sequence number far ahead.
        ahead = (driver.seq + 20000) & 0xFFFF
        uno.cable.inject(proto.set_watchdog(ahead, proto.WATCHDOG_DEFAULT_MS))
        await hold(driver, {"jaw": 1234.0}, uno, {11: 1234})
        assert driver.nacks["STALE_SEQUENCE"] >= 1
        assert (driver.seq - ahead) & 0xFFFF < 1000  # continues after the board's last_seq
    finally:
        await driver.close()


async def test_a_silent_board_is_reopened(uno: UnoRig) -> None:
    profile = load_profile("paper16")
    driver = await connected(uno, profile, connect_timeout=1.0)
    try:
        await hold(driver, {"jaw": 1800.0}, uno, {11: 1800})
        os.kill(uno.board.proc.pid, signal.SIGSTOP)  # the board hangs; the port stays open
        try:
            for _ in range(80):
                await driver.send({"jaw": 1700.0}, INFO)
                await asyncio.sleep(0.05)
                if driver.link.state.losses:
                    break
            assert driver.link.state.losses == 1, driver.state()
            assert "no reply from the firmware" in driver.link.state.last_error
        finally:
            os.kill(uno.board.proc.pid, signal.SIGCONT)
        await hold(driver, {"jaw": 1300.0}, uno, {11: 1300})
        assert driver.link.state.connects >= 2
    finally:
        await driver.close()


async def test_missing_pca9685_shows_in_the_state(firmware_ready: None, tmp_path: Path) -> None:
    rig = UnoRig(tmp_path, cable=False, extra=("--no-board",))
    driver = await connected(rig, load_profile("paper16"))
    try:
        for _ in range(40):
            await driver.send({"jaw": 1600.0}, INFO)
            await asyncio.sleep(0.05)
            if driver.output_fault:
                break
        assert "PCA9685 not answering" in driver.state()
        assert (await driver.device_status())["output_errors"] >= 1
    finally:
        await driver.close()
        rig.close()


async def test_more_servos_than_the_board_has_is_a_clear_error(
    firmware_ready: None, tmp_path: Path
) -> None:
    rig = UnoRig(tmp_path, cable=False, output="pins")
    driver = ArduinoDriver(ArduinoConfig(port=str(rig.port)), load_profile("paper16"))
    try:
        with pytest.raises(
            DriverConfigError,
            match=r"channel 15, but the firmware's PINS build has channels 0\.\.11",
        ):
            await driver.connect()
    finally:
        await driver.close()
        rig.close()


def test_profile_limits_the_firmware_refuses_are_named(tmp_path: Path) -> None:
    profile = varied_profile(tmp_path, [0])
    profile.servos[0].min_us = 400
    with pytest.raises(
        DriverConfigError, match=r"servo 's0' \(channel 0\): limits 400\.\.2000 us are outside"
    ):
        ArduinoDriver(ArduinoConfig(port="/dev/null"), profile)
    wide = varied_profile(tmp_path, [16])
    with pytest.raises(DriverConfigError, match=r"has channels 0\.\.15"):
        ArduinoDriver(ArduinoConfig(port="/dev/null"), wide)


def frame_times(rig: UnoRig) -> list[tuple[float, float, proto.Frame]]:
    """(first byte, last byte) emulated µs of every command frame the firmware received."""
    decoder = proto.FrameDecoder()
    times: list[float] = []
    out = []
    for t, byte in rig.board.events("rx"):
        times.append(float(t))
        for frame in decoder.feed(bytes([int(byte, 16)])):
            size = len(frame.payload) + proto.FRAME_OVERHEAD
            out.append((times[-size], times[-1], frame))
    return out


async def test_command_to_pulse_latency_through_the_driver(uno: UnoRig, tmp_path: Path) -> None:
    """Emulated time from the first byte of a SET_ALL on the wire to the PCA9685 latching all
    16 channels (README figure; run with -s to see it). No rate limits: each width jumps."""
    profile = varied_profile(tmp_path, rate_limits=False)
    driver = await connected(uno, profile)
    totals, wires = [], []
    try:
        for i in range(20):
            us = 1100 + 37 * i
            before = len(uno.pulses())
            await driver.send({s.name: float(us) for s in profile.servos}, INFO)
            for _ in range(200):
                await asyncio.sleep(0.02)
                if len(uno.pulses()) - before >= 16:
                    break
            first, last, _frame = [x for x in frame_times(uno) if x[2].code == SET_ALL][-1]
            latched = max(p.t_us for p in uno.pulses()[before:])
            totals.append(latched - first)
            wires.append(last - first)
            await asyncio.sleep(0.06)
    finally:
        await driver.close()
    print(
        "\narduino driver -> emulated Uno: SET_ALL on the wire "
        f"{statistics.median(wires) / 1000:.2f} ms "
        f"(simavr: 11 bits/byte), first byte -> all 16 channels latched "
        f"{statistics.median(totals) / 1000:.2f} ms median (max {max(totals) / 1000:.2f})"
    )
    assert max(totals) < 10_000
