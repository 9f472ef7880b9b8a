"""The real ``facesynth control --driver arduino --port PTY`` process, fed servo commands through
a real Zenoh router, driving the real firmware on the emulated Uno.

Checks what the emulated PCA9685 outputs: every channel at its commanded width (to within a
4.88 µs step), clamped to the profile's limits; neutral when commands stop (the control
service's watchdog) and when the control process dies (the firmware's own, in emulated time);
corrupted, cut-off and replayed frames on the line change nothing; pulling the cable or
restarting the board needs no restart of the control process.
"""

from __future__ import annotations

import asyncio
import contextlib
import re
import signal
import subprocess
import sys
from collections.abc import AsyncIterator, Iterator
from pathlib import Path

import pytest
from facesynth_processes import Processes
from profile_files import write_profile
from uno_rig import UnoRig

from facesynth.runtime import codec, keys
from facesynth.runtime.bus.zenoh_bus import ZenohBus, ZenohOptions
from facesynth.schemas.messages import ServiceStats, ServoCommands
from facesynth.services.control.drivers.arduino import protocol as proto

pytestmark = pytest.mark.firmware

SET_ALL = proto.COMMANDS["SET_ALL"].code
NEUTRAL = {ch: 1400 + 10 * ch for ch in range(16)}


def limits(ch: int) -> tuple[int, int]:
    return 900 + 10 * ch, 2000 + 10 * ch


@pytest.fixture
def profile_path(tmp_path: Path) -> Path:
    servos = [
        {
            "name": f"s{ch}",
            "channel": ch,
            "min_us": limits(ch)[0],
            "neutral_us": NEUTRAL[ch],
            "max_us": limits(ch)[1],
        }
        for ch in range(16)
    ]
    return write_profile(tmp_path / "face.toml", servos)


class Feeder:
    """Publishes a pose on ``…/servo_commands`` every 50 ms (as T would), until paused."""

    def __init__(self, bus: ZenohBus, rig: str) -> None:
        self.bus = bus
        self.key = keys.stage_key(rig, "servo_commands")
        self.pose: dict[int, float] | None = None
        self.seq = 0
        self.task: asyncio.Task[None] | None = None

    def start(self, pose: dict[int, float]) -> None:
        self.pose = pose
        if self.task is None:
            self.task = asyncio.create_task(self._run())

    async def pause(self) -> None:
        if self.task is not None:
            self.task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self.task
            self.task = None

    async def _run(self) -> None:
        while True:
            assert self.pose is not None
            message = ServoCommands(
                seq=self.seq,
                t_capture_ns=1,
                t_media_ns=self.seq,
                face=True,
                profile="testface",
                positions={f"s{ch}": us for ch, us in self.pose.items()},
            )
            self.bus.publish(self.key, codec.encode(message))
            self.seq += 1
            await asyncio.sleep(0.05)


@pytest.fixture
async def feeder(zenoh_router: str, rig: str) -> AsyncIterator[Feeder]:
    bus = await asyncio.to_thread(
        ZenohBus.open, ZenohOptions(mode="client", connect=[zenoh_router])
    )
    made = Feeder(bus, rig)
    yield made
    await made.pause()
    await bus.close()


@pytest.fixture
def direct_uno(firmware_ready: None, tmp_path: Path) -> Iterator[UnoRig]:
    """An emulated Uno whose own pty is the port (it vanishes when the board restarts)."""
    made = UnoRig(tmp_path / "direct", cable=False)
    yield made
    made.close()


def start_control(
    processes: Processes, uno: UnoRig, profile: Path, router: str, rig: str, *extra: str
) -> subprocess.Popen[bytes]:
    return processes.start(
        "control",
        "--driver",
        "arduino",
        "--port",
        str(uno.port),
        "--profile",
        str(profile),
        "--connect",
        router,
        "--rig",
        rig,
        "--stats-interval",
        "0.2",
        *extra,
        name="control",
    )


def pose_with_extremes() -> dict[int, float]:
    """Distinct widths; channels 0-3 far outside their limits."""
    pose = {ch: 1100.0 + 53 * ch for ch in range(16)}
    pose.update({0: 100.0, 1: 2900.0, 2: 0.0, 3: 5000.0})
    return pose


def clamped(pose: dict[int, float]) -> dict[int, float]:
    return {ch: min(max(us, limits(ch)[0]), limits(ch)[1]) for ch, us in pose.items()}


def status_report(port: Path, profile: Path) -> dict[str, str]:
    """``facesynth control status`` (a separate process), as key -> value."""
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "facesynth",
            "control",
            "status",
            "--driver",
            "arduino",
            "--port",
            str(port),
            "--profile",
            str(profile),
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 0, result.stderr
    return dict(
        re.split(r"\s{2,}", line.strip(), maxsplit=1)
        for line in result.stdout.splitlines()
        if "  " in line.strip()
    )


async def test_commands_reach_every_channel_clamped_then_neutral_when_they_stop(
    uno: UnoRig,
    profile_path: Path,
    zenoh_router: str,
    rig: str,
    feeder: Feeder,
    processes: Processes,
) -> None:
    control = start_control(processes, uno, profile_path, zenoh_router, rig)
    feeder.start(pose_with_extremes())
    await uno.settle(clamped(pose_with_extremes()), timeout=30)
    for frame in uno.commands():
        if frame.code == SET_ALL:
            widths = [int.from_bytes(frame.payload[i : i + 2], "little") for i in range(0, 32, 2)]
            assert all(limits(ch)[0] <= us <= limits(ch)[1] for ch, us in enumerate(widths))
    await feeder.pause()  # commands stop: after 0.5 s the face ramps to neutral (0.2 s)
    await uno.settle(NEUTRAL, timeout=5)
    assert control.poll() is None, processes.log("control")
    control.send_signal(signal.SIGTERM)
    assert control.wait(timeout=15) == 0, processes.log("control")
    report = status_report(uno.port, profile_path)
    assert report["clamped"] == "0"  # the control service clamped before the firmware had to
    assert "LIMITS_SET" in report["flags"]


async def test_the_firmware_watchdog_when_the_control_process_dies(
    uno: UnoRig,
    profile_path: Path,
    zenoh_router: str,
    rig: str,
    feeder: Feeder,
    processes: Processes,
) -> None:
    control = start_control(processes, uno, profile_path, zenoh_router, rig)
    pose = {ch: 1700.0 for ch in range(16)}
    feeder.start(pose)
    await uno.settle(pose, timeout=30)
    control.kill()  # no clean shutdown: nobody sends NEUTRAL
    control.wait(timeout=10)
    await feeder.pause()
    before = len(uno.pulses())
    await uno.settle(NEUTRAL, timeout=5)
    last_rx = float(uno.board.events("rx")[-1][0])
    back = [p for p in uno.pulses()[before:] if abs(p.width_us - NEUTRAL[p.channel]) < 3]
    delay_ms = (min(p.t_us for p in back) - last_rx) / 1000
    assert 499 <= delay_ms <= 503, delay_ms  # 500 ms after the last byte, in emulated time


async def test_corrupted_cut_off_and_replayed_frames_change_nothing(
    uno: UnoRig,
    profile_path: Path,
    zenoh_router: str,
    rig: str,
    feeder: Feeder,
    processes: Processes,
) -> None:
    control = start_control(
        processes,
        uno,
        profile_path,
        zenoh_router,
        rig,
        "--watchdog",
        "30",
        "--board-watchdog-ms",
        "60000",
    )
    first = {ch: 1200.0 + 10 * ch for ch in range(16)}
    feeder.start(first)
    await uno.settle(first, timeout=30)
    second = {ch: 1800.0 - 10 * ch for ch in range(16)}
    feeder.start(second)
    await uno.settle(second)
    await feeder.pause()
    await asyncio.sleep(0.2)
    assert uno.cable is not None
    sent = proto.FrameDecoder().feed(bytes(uno.cable.from_host))
    old = next(
        f for f in sent if f.code == SET_ALL and f.payload[:2] == (1200).to_bytes(2, "little")
    )
    old_frame = proto.encode_frame(old.seq, old.code, old.payload)
    pulses = len(uno.pulses())
    uno.cable.inject(old_frame)  # replayed: a stale sequence number
    corrupt = bytearray(proto.encode_frame((old.seq + 40000) & 0xFFFF, old.code, old.payload))
    corrupt[9] ^= 0x10
    uno.cable.inject(bytes(corrupt))  # a flipped bit: bad CRC
    await asyncio.sleep(0.2)
    uno.cable.inject(old_frame[:20])  # cut off, then silence
    await asyncio.sleep(0.2)
    uno.cable.inject(b"\x00garbage\xff\xa5\xff")  # bytes outside any frame, a false start
    await asyncio.sleep(0.5)
    assert uno.pulses()[pulses:] == []  # no servo moved
    third = {ch: 1500.0 + 20 * ch for ch in range(16)}
    feeder.start(third)  # the driver resynchronised after the stale NACK and carries on
    await uno.settle(third)
    await feeder.pause()
    assert control.poll() is None
    control.send_signal(signal.SIGTERM)
    assert control.wait(timeout=15) == 0, processes.log("control")
    report = status_report(uno.port, profile_path)
    assert int(report["crc_errors"]) >= 1 and int(report["truncated"]) >= 1
    assert int(report["stale_sequence"]) >= 1 and int(report["dropped_bytes"]) >= 1


async def test_pulling_the_cable_needs_no_restart(
    uno: UnoRig,
    profile_path: Path,
    zenoh_router: str,
    rig: str,
    feeder: Feeder,
    processes: Processes,
) -> None:
    bus = await asyncio.to_thread(
        ZenohBus.open, ZenohOptions(mode="client", connect=[zenoh_router])
    )
    stats = bus.subscribe_queued(keys.stats_pattern(rig), 256)
    try:
        control = start_control(processes, uno, profile_path, zenoh_router, rig)
        feeder.start({ch: 1300.0 for ch in range(16)})
        await uno.settle({ch: 1300.0 for ch in range(16)}, timeout=30)
        assert uno.cable is not None
        uno.cable.unplug()
        notes = []
        for _ in range(50):
            sample = await asyncio.wait_for(stats.receive(), 5)
            notes.append(codec.decode(sample.payload, ServiceStats).note)
            if "disconnected" in notes[-1]:
                break
        assert "disconnected from" in notes[-1], notes
        assert control.poll() is None
        uno.cable.plug()
        feeder.start({ch: 1750.0 for ch in range(16)})
        await uno.settle({ch: 1750.0 for ch in range(16)}, timeout=15)
        assert control.poll() is None
        log = processes.log("control")
        assert "device lost" in log and "connected (connected to" in log
        assert len([e for e in uno.board.events("reg") if e[1] == "PRE_SCALE"]) == 1  # no reboot
    finally:
        await bus.close()


async def test_restarting_the_board_needs_no_restart(
    direct_uno: UnoRig,
    profile_path: Path,
    zenoh_router: str,
    rig: str,
    feeder: Feeder,
    processes: Processes,
) -> None:
    uno = direct_uno
    control = start_control(
        processes,
        uno,
        profile_path,
        zenoh_router,
        rig,
        "--watchdog",
        "30",
        "--board-watchdog-ms",
        "60000",
    )
    pose = {ch: 1600.0 + 7 * ch for ch in range(16)}
    feeder.start(pose)
    await uno.settle(pose, timeout=30)
    await feeder.pause()
    uno.restart()  # power cycle: the pty goes away, a new board boots at 1500 us
    # No new command: the driver reconnects, sends the limits, and the pose it holds.
    await uno.settle(pose, timeout=15)
    codes = [f.code for f in uno.commands()]
    assert proto.COMMANDS["SET_LIMITS"].code in codes and SET_ALL in codes
    assert control.poll() is None
    control.send_signal(signal.SIGTERM)
    assert control.wait(timeout=15) == 0, processes.log("control")
    await uno.settle(NEUTRAL)  # NEUTRAL on shutdown: the firmware's neutral is the profile's
