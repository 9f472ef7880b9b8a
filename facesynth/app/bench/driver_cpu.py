"""``facesynth bench drivers --emulated``: C's CPU per frame and the bus bytes, measured.

Each driver runs as the control service runs it, against its device emulator: a pose of the
profile's 16 servos every frame at ``--fps`` (every servo somewhere new each frame), and per
frame the three calls the service makes, ``state()``, ``send()`` and ``readings()``. The CPU
figure is this process's CPU time (``time.process_time``: every thread, so the smart buses'
bus thread and the PCA9685's I2C thread count) over ``--frames`` frames, divided by the frames;
the poses are made before the clock starts.

The serial devices (Maestro, SSC-32, the Dynamixel and Feetech buses) run in a child process
on a pty (:mod:`.device_host`), so their CPU is not counted; they count the bytes on the line
each way, and the bus time measured is those bytes at the driver's baud rate (8N1: 10 bits a
byte): on average per frame, and for the frames that carried a read-back (a smart bus reads
back at ``--bus-read-hz``, not at every frame), next to the one computed from the packet
sizes. The PCA9685 is the register model behind
smbus2's interface, in this process: the CPU its calls take (their thread time) is taken off.
The emulators are the test suite's (``tests/control/fake_devices``): a source checkout only.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from facesynth.app.bench.device_host import Counts, DeviceHost
from facesynth.app.wiring import OptionError
from facesynth.runtime.profiles import Profile
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.base import ServoDriver
from facesynth.services.control.drivers.bus_servo.budget import wire_s

#: Where the emulators live in a source checkout (the parent of ``fake_devices``).
FAKE_DEVICES = Path(__file__).resolve().parents[3] / "tests" / "control"
WARMUP_FRAMES = 15


@dataclass(frozen=True)
class Case:
    """One driver against one emulator: a row of the table."""

    label: str
    kind: str  # device_host kind, or "pca9685" (the register model, in process)
    config: dict[str, Any]  # the driver's table, ``port`` filled in


CASES = (
    Case("maestro", "maestro", {"driver": "maestro", "model": "mini24"}),
    Case("ssc32", "ssc32", {"driver": "ssc32"}),
    Case(
        "dynamixel 2.0",
        "dynamixel2",
        {"driver": "dynamixel", "baud": 1000000, "protocol": 2},
    ),
    Case(
        "dynamixel 1.0",
        "dynamixel1",
        {"driver": "dynamixel", "baud": 1000000, "protocol": 1},
    ),
    Case("feetech", "feetech", {"driver": "feetech", "baud": 1000000}),
    Case("pca9685", "pca9685", {"driver": "pca9685", "exit_hold_s": 0.0}),
)


@dataclass(frozen=True)
class CpuRun:
    """One driver's run: CPU and bytes per frame."""

    label: str
    frames: int
    cpu_ms: float  # per frame
    bytes_out: float  # per frame, driver -> device
    bytes_back: float  # per frame, device -> driver
    baud: int | None
    computed_ms: float | None  # bus time per frame from the packet sizes (smart buses)
    servos_read: int | None
    read_frames: int = 0  # frames that carried a read-back, counted by the emulator
    read_frame_bytes: float = 0.0  # their bytes both ways: median
    read_frame_max: int = 0  # and largest

    @property
    def measured_ms(self) -> float | None:
        """Bus time per frame of the bytes the emulator counted, at the driver's baud."""
        if self.baud is None or math.isnan(self.bytes_out):
            return None
        return wire_s(round(self.bytes_out + self.bytes_back), self.baud) * 1000

    @property
    def read_frame_ms(self) -> tuple[float, float] | None:
        """Bus time of a frame with a read-back, measured: median and largest."""
        if self.baud is None or not self.read_frames:
            return None
        return (
            wire_s(round(self.read_frame_bytes), self.baud) * 1000,
            wire_s(self.read_frame_max, self.baud) * 1000,
        )


def check_checkout() -> Path:
    """The emulators' folder, or an :class:`OptionError` saying a checkout is needed."""
    if not (FAKE_DEVICES / "fake_devices" / "dynamixel.py").is_file():
        raise OptionError(
            "--emulated drives the device emulators of a source checkout "
            f"(tests/control/fake_devices, not found under {FAKE_DEVICES.parents[1]}); "
            "run it from a clone of facesynth"
        )
    return FAKE_DEVICES


def check_options(*, frames: int, fps: float, repeat: int) -> None:
    """The run's options, each checked (:class:`OptionError`), and the checkout."""
    if frames < 1:
        raise OptionError("--frames must be at least 1")
    if repeat < 1:
        raise OptionError("--repeat must be at least 1")
    if not fps > 0 or not math.isfinite(fps):
        raise OptionError(f"--fps must be a positive number, not {fps:g}")
    check_checkout()


def poses(profile: Profile, count: int) -> list[dict[str, float]]:
    """``count`` poses, every servo somewhere new each frame, inside its limits."""
    out = []
    for frame in range(count):
        pose = {}
        for i, spec in enumerate(profile.servos):
            share = 0.5 + 0.4 * math.sin(frame * 0.21 + i * 0.7)
            pose[spec.name] = spec.min_us + (spec.max_us - spec.min_us) * share
        out.append(pose)
    return out


class _TimedBus:
    """The PCA9685 model's bus, adding the CPU (thread time) of its calls to ``spent``."""

    def __init__(self, bus: Any, spent: list[float]) -> None:
        self._bus = bus
        self._spent = spent

    def __getattr__(self, name: str) -> Any:
        attr = getattr(self._bus, name)
        if not callable(attr):
            return attr
        spent = self._spent

        def timed(*args: Any, **kwargs: Any) -> Any:
            start = time.thread_time()
            try:
                return attr(*args, **kwargs)
            finally:
                spent[0] += time.thread_time() - start

        return timed


@contextlib.contextmanager
def _device(
    case: Case, parent: Path, folder: Path, profile: Profile
) -> Iterator[tuple[ServoDriver, Callable[[], Counts] | None, list[float]]]:
    """The driver for ``case`` on its emulator; a byte counter (serial devices) and the
    emulator's own CPU seconds measured in this process (the PCA9685 model)."""
    from facesynth.services.control.drivers.registry import DRIVERS

    spent = [0.0]
    if case.kind == "pca9685":
        from facesynth.services.control.drivers.pca9685 import PCA9685Config, PCA9685Driver

        sys.path.insert(0, str(parent))
        from fake_devices.pca9685 import FakeI2CAdapter, FakePCA9685

        adapter = FakeI2CAdapter(folder / "i2c-1", FakePCA9685())
        config = DRIVERS.parse({**case.config, "bus": str(adapter.path)})
        assert isinstance(config, PCA9685Config)
        yield (
            PCA9685Driver(config, profile, open_bus=lambda p: _TimedBus(adapter.open(p), spent)),
            None,
            spent,
        )
        return
    link = folder / f"tty-{case.kind}"
    with contextlib.closing(DeviceHost(parent, case.kind, link)) as host:
        driver = DRIVERS.build(DRIVERS.parse({**case.config, "port": str(link)}), profile)
        yield driver, host.count, spent


async def _drive(
    driver: ServoDriver, frames: list[dict[str, float]], fps: float, mark: Callable[[], None]
) -> None:
    """Every pose at ``fps``, as the control service hands them over; ``mark`` is called
    after the warm-up frames."""
    loop = asyncio.get_running_loop()
    period = 1 / fps
    due = loop.time()
    for index, pose in enumerate(frames):
        if index == WARMUP_FRAMES:
            mark()
        info = CommandInfo(frame=index, t_capture_ns=None, face=True)
        driver.state()
        await driver.send(pose, info)
        driver.readings()
        due += period
        await asyncio.sleep(max(0.0, due - loop.time()))


def run_case(case: Case, profile: Profile, frames: int, fps: float) -> CpuRun:
    """One driver's run against its emulator."""
    parent = check_checkout()
    all_poses = poses(profile, frames + WARMUP_FRAMES)
    with (
        tempfile.TemporaryDirectory(prefix="facesynth-bench-") as tmp,
        _device(case, parent, Path(tmp), profile) as (driver, count, spent),
    ):
        marks: dict[str, float] = {}

        def mark() -> None:
            if count is not None:
                count()
            spent[0] = 0.0
            marks["cpu"] = time.process_time()

        async def go() -> tuple[float, Counts | None]:
            await driver.connect_once()
            try:
                await _drive(driver, all_poses, fps, mark)
                cpu = time.process_time() - marks["cpu"] - spent[0]
                return cpu, count() if count is not None else None
            finally:
                await driver.close()

        cpu, counted = asyncio.run(go())
    baud = getattr(driver, "baud", None) or getattr(getattr(driver, "link", None), "baud", None)
    computed = read = None
    frame_bus_ms = getattr(driver, "frame_bus_ms", None)
    if frame_bus_ms is not None:
        write_ms, read_ms, read = frame_bus_ms()
        computed = write_ms + read_ms
    got, sent, read_frames, median, largest = counted or (math.nan, math.nan, 0, 0.0, 0)
    return CpuRun(
        case.label,
        frames,
        cpu * 1000 / frames,
        got / frames,
        sent / frames,
        baud if counted is not None else None,
        computed,
        read,
        read_frames,
        median,
        largest,
    )


def bench_cpu(
    profile: Profile, *, frames: int, fps: float, repeat: int, cases: tuple[Case, ...] = CASES
) -> list[list[CpuRun]]:
    """Every case, ``repeat`` interleaved rounds; the runs of each case."""
    check_options(frames=frames, fps=fps, repeat=repeat)
    runs: list[list[CpuRun]] = [[] for _ in cases]
    for _ in range(repeat):
        for index, case in enumerate(cases):
            runs[index].append(run_case(case, profile, frames, fps))
    return runs


def _cell(value: float | None, spec: str, width: int) -> str:
    return f"{value:{width}{spec}}" if value is not None else f"{'-':>{width}}"


def format_cpu(profile: Profile, runs: list[list[CpuRun]], fps: float) -> str:
    """The side-by-side table: CPU ms per frame (median of the rounds, and the spread), bytes
    each way, bus time measured (per frame, and per frame with a read-back) and computed."""
    first = runs[0][0]
    lines = [
        "",
        f"C's CPU per frame, measured: {len(profile.servos)} servos of profile {profile.name}, "
        f"{first.frames} frames at {fps:g} fps per run, {len(runs[0])} round(s), each driver "
        "against its emulator",
        f"{'driver':<14} {'cpu ms':>6} {'min..max':>11} {'vs maestro':>10} {'out B':>6} "
        f"{'back B':>6} {'baud':>7} {'bus ms':>6} {'read frame ms':>13} {'computed':>8} "
        f"{'read':>4}",
    ]
    maestro = statistics.median(r.cpu_ms for r in runs[0]) if runs[0][0].label == "maestro" else 0
    for case_runs in runs:
        run = case_runs[0]
        cpu = statistics.median(r.cpu_ms for r in case_runs)
        low, high = min(r.cpu_ms for r in case_runs), max(r.cpu_ms for r in case_runs)
        ratio = f"{cpu / maestro - 1:+.0%}" if maestro else "-"
        measured = [r.measured_ms for r in case_runs if r.measured_ms is not None]
        reads = [r.read_frame_ms for r in case_runs if r.read_frame_ms is not None]
        read_ms = (
            f"{statistics.median(m for m, _ in reads):.2f}/{max(x for _, x in reads):.2f}"
            if reads
            else "-"
        )
        out_b = statistics.median(r.bytes_out for r in case_runs)
        back_b = statistics.median(r.bytes_back for r in case_runs)
        lines.append(
            f"{run.label:<14} {cpu:>6.3f} {f'{low:.3f}..{high:.3f}':>11} {ratio:>10} "
            f"{_cell(None if math.isnan(out_b) else out_b, '.0f', 6)} "
            f"{_cell(None if math.isnan(back_b) else back_b, '.0f', 6)} "
            f"{_cell(run.baud, 'd', 7)} "
            f"{_cell(statistics.median(measured) if measured else None, '.2f', 6)} "
            f"{read_ms:>13} {_cell(run.computed_ms, '.2f', 8)} {_cell(run.servos_read, 'd', 4)}"
        )
    lines.append(
        "(cpu ms: process CPU time per frame of state(), send() and readings() and the "
        "drivers' own threads; out/back B: bytes per frame counted by the emulator; bus ms: "
        "those bytes at the baud rate, 10 bits a byte, without the servos' return delay; read "
        "frame ms: a frame with a read-back, measured the same way, median/largest; computed: "
        "such a frame from the packet sizes; read: servos read back per read-back. The "
        "PCA9685 model's own CPU is taken off; its I2C bytes are not counted.)"
    )
    return "\n".join(lines)
