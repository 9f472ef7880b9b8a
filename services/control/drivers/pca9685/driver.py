"""The ``pca9685`` driver: a PCA9685 on the host's own I2C bus (a Raspberry Pi's pins), with smbus2.

On every connect the driver programs the chip in the datasheet's order (section 7.3.1.1):
MODE1 with SLEEP (the oscillator off), PRE_SCALE (writable only while asleep), MODE1 awake
with register auto-increment, at least 500 µs for the oscillator, then RESTART if the chip
asks for it; then it writes the pose. Every pose is one I2C write: the register address and
4 bytes per channel from the lowest channel to the highest (65 bytes for 16 channels, past
SMBus's 32-byte block limit, so it goes out as one plain I2C message through ``i2c_rdwr``).
At close the face goes to neutral, is held there ``exit_hold_s`` (a servo moves only while it
gets pulses), and the chip sleeps (no pulses: analog servos relax).

I2C calls block, so they run on one worker thread, in order, off the event loop; ``send``
hands the pose over without waiting for the bus (a newer pose replaces one not yet written).
A chip that stops answering (its power lost, a loose wire) is reopened with backoff and
programmed again, as the serial boards are: meanwhile poses are counted and dropped and the
pose held follows them.

The bus is opened through a seam, ``open_bus(path)`` (smbus2's ``SMBus`` in production); the
tests pass a register-level model of the chip there.
"""

from __future__ import annotations

import asyncio
import contextlib
import errno as errnos
import functools
import logging
import os
import threading
import time
from collections.abc import Callable, Mapping
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any

from facesynth.runtime.profiles import Profile
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers._extras import require
from facesynth.services.control.drivers.base import (
    DeviceUnavailable,
    DriverError,
    FoundDevice,
    ServoDriver,
)
from facesynth.services.control.drivers.pca9685 import registers as reg
from facesynth.services.control.drivers.pca9685.config import (
    BusOpener,
    I2CBus,
    PCA9685Config,
    bus_path,
)
from facesynth.services.control.drivers.registry import DRIVERS
from facesynth.services.control.drivers.serial_link import Backoff, LinkState
from facesynth.services.control.drivers.servo_map import ServoMap

log = logging.getLogger("facesynth.control.pca9685")


def _reason(exc: BaseException) -> str:
    number = getattr(exc, "errno", None)
    if isinstance(exc, OSError) and isinstance(number, int) and number > 0:
        return os.strerror(number)
    return (str(exc).strip() or type(exc).__name__).splitlines()[0]


@DRIVERS.register(PCA9685Config)
class PCA9685Driver(ServoDriver):
    """A PCA9685 on I2C: the pose as one auto-increment block write, sleep at close."""

    needs_extra = "pca9685"
    board = "PCA9685"

    def __init__(
        self, config: PCA9685Config, profile: Profile, *, open_bus: BusOpener | None = None
    ) -> None:
        self._smbus2 = require("smbus2", plugin="pca9685 driver", package="smbus2", extra="pca9685")
        self.config = config
        self.path = bus_path(config.bus)
        self.address = reg.parse_address(config.address)
        self.prescale = reg.prescale(config.oscillator_hz, config.frequency_hz)
        self.tick_us = reg.tick_us(self.prescale, config.oscillator_hz)
        self.map = ServoMap(
            profile,
            board=f"PCA9685 at {config.frequency_hz:g} Hz",
            step_us=self.tick_us,
            range_us=(self.tick_us, (reg.TICKS - 1) * self.tick_us),
            channels=reg.CHANNELS,
        )
        self.pose: dict[int, int] = self.map.neutral_pose()
        self.status = LinkState(f"{self.path} 0x{self.address:02x}")
        self.query_only = False
        self._open_bus: BusOpener = open_bus or self._smbus2.SMBus
        self._bus: I2CBus | None = None
        self._executor: ThreadPoolExecutor | None = None
        self._supervisor: asyncio.Task[None] | None = None
        self._backoff = Backoff()
        # The newest pose not yet written, and whether a write runs (the I2C thread takes it).
        self._slot = threading.Lock()
        self._latest: dict[int, int] | None = None
        self._writing = False

    # -- the seam ----------------------------------------------------------------------------

    async def connect(self) -> None:
        """Open and program the chip; if it does not answer, keep trying in the background."""
        self._start()
        try:
            await self._run(self._connect_blocking)
        except DeviceUnavailable as exc:
            self._failed(str(exc))
            self._supervise()

    async def connect_once(self, *, query_only: bool = False) -> None:
        """Open now or raise :class:`DeviceUnavailable`; ``query_only``: only read registers."""
        self.query_only = query_only
        self._start()
        try:
            await self._run(self._connect_blocking)
        except DeviceUnavailable:
            await self.close()
            raise

    async def send(self, positions: Mapping[str, float], info: CommandInfo) -> None:
        """Update the pose and hand it to the I2C thread without waiting for the bus (a pose
        still waiting when a newer one comes is replaced by it); dropped and counted while the
        chip does not answer."""
        executor = self._executor
        if executor is None:
            raise DriverError(f"{self.status.port}: the pca9685 driver is not connected")
        self.pose = self.map.pose(positions, self.pose)
        if not self.status.connected:
            self.status.writes_dropped += 1
            return
        with self._slot:
            self._latest = self.pose
            start, self._writing = not self._writing, True
        if start:
            done = executor.submit(self._write_latest)
            done.add_done_callback(functools.partial(self._written, asyncio.get_running_loop()))

    async def flush(self) -> None:
        """Wait until the poses handed to the I2C thread are written."""
        if self._executor is not None:
            await self._run(lambda: None)

    async def close(self) -> None:
        """Neutral, held ``exit_hold_s``, then SLEEP; release the bus."""
        if self._supervisor is not None:
            self._supervisor.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._supervisor
            self._supervisor = None
        if self._executor is None:
            return
        if self.status.connected and not self.query_only:
            try:
                await self._run(self._park)
            except DeviceUnavailable as exc:
                log.warning("%s: could not put the board to sleep: %s", self.status.port, exc)
        await self._run(self._close_bus)
        self._executor.shutdown(wait=True)
        self._executor = None
        self.status.connected = False

    def state(self) -> str:
        """Connected, or why not; the PWM frequency the chip makes."""
        hz = self.config.oscillator_hz / (reg.TICKS * (self.prescale + 1))
        return f"{self.status.describe()}; {hz:.2f} Hz, {self.tick_us:.2f} us steps"

    async def device_status(self) -> dict[str, Any]:
        """MODE1, MODE2, PRE_SCALE and each servo's pulse width, read from the chip."""
        if not self.status.connected:
            raise DeviceUnavailable(f"{self.status.port}: {self.status.describe()}")
        return await self._run(self._read_status)

    async def found(self) -> list[FoundDevice]:
        """The chip at its address, with the frame rate and state its registers hold."""
        status = await self.device_status()
        asleep = "asleep" if "asleep" in status["mode1"] else "running"
        model = (
            f"PCA9685 (MODE1 {status['mode1'].split()[0]}, {asleep}, PRE_SCALE "
            f"{status['prescale']}: {status['frequency_hz']:g} Hz)"
        )
        channels = self.map.channels
        servos = f"{len(channels)} servos on channels {channels[0]}..{channels[-1]}"
        return [FoundDevice(status["address"], model, servo=servos)]

    def positions_us(self) -> dict[str, float]:
        """The pose the driver holds, in µs by servo name."""
        return {lim.name: self.map.us(self.pose[ch]) for ch, lim in self.map.limits.items()}

    # -- on the event loop -------------------------------------------------------------------

    def _start(self) -> None:
        if self._executor is None:
            self._executor = ThreadPoolExecutor(1, thread_name_prefix="pca9685")

    async def _run(self, call: Callable[..., Any], *args: Any) -> Any:
        assert self._executor is not None
        return await asyncio.get_running_loop().run_in_executor(self._executor, call, *args)

    def _written(self, loop: asyncio.AbstractEventLoop, done: Future[None]) -> None:
        """(On the I2C thread.) A write that failed tells the loop the chip is lost."""
        exc = done.exception()
        if exc is not None:
            with contextlib.suppress(RuntimeError):  # the loop has closed
                loop.call_soon_threadsafe(self._lost, exc)

    def _lost(self, exc: BaseException) -> None:
        if not self.status.connected or self._executor is None:
            return
        self.status.connected = False
        self.status.losses += 1
        self._failed(str(exc))
        log.warning("%s: lost (%s); trying again", self.status.port, exc)
        self._supervise()

    def _failed(self, reason: str) -> None:
        self.status.failed_attempts += 1
        self.status.last_error = reason.removeprefix(f"{self.path}: ")

    def _supervise(self) -> None:
        if self._supervisor is None or self._supervisor.done():
            self._supervisor = asyncio.create_task(self._reconnect(), name="pca9685 reconnect")

    async def _reconnect(self) -> None:
        while not self.status.connected:
            await asyncio.sleep(self._backoff.next())
            try:
                await self._run(self._connect_blocking)
            except DeviceUnavailable as exc:
                self._failed(str(exc))
        log.info("%s: connected again", self.status.port)

    # -- on the I2C thread -------------------------------------------------------------------

    def _connect_blocking(self) -> None:
        try:
            if self._bus is None:
                self._bus = self._open_bus(self.path)
        except OSError as exc:
            raise DeviceUnavailable(f"{self.path}: cannot open it: {_reason(exc)}") from None
        try:
            mode1 = self._bus.read_byte_data(self.address, reg.MODE1)
            if not self.query_only:
                self._program(mode1)
                written: dict[int, int] | None = None
                while written != self.pose:  # a send may change it meanwhile
                    written = dict(self.pose)
                    self._write_block(written)
        except OSError as exc:
            self._close_bus()
            raise self._no_answer(exc) from None
        self.status.connected = True
        self.status.connects += 1
        self.status.failed_attempts = 0
        self.status.last_error = ""
        self._backoff.reset()

    def _program(self, mode1: int) -> None:
        """Sleep, PRE_SCALE, wake with auto-increment, 500 µs, RESTART (datasheet 7.3.1.1)."""
        assert self._bus is not None
        keep = mode1 & reg.KEEP
        bus, address = self._bus, self.address
        bus.write_byte_data(address, reg.MODE1, keep | reg.AI | reg.SLEEP)
        bus.write_byte_data(address, reg.PRE_SCALE, self.prescale)
        bus.write_byte_data(address, reg.MODE2, reg.OUTDRV)
        bus.write_byte_data(address, reg.MODE1, keep | reg.AI)
        awake = time.monotonic()
        while (left := reg.WAKE_S - (time.monotonic() - awake)) > 0:
            time.sleep(left)
        if bus.read_byte_data(address, reg.MODE1) & reg.RESTART:
            bus.write_byte_data(address, reg.MODE1, keep | reg.AI | reg.RESTART)

    def _write_latest(self) -> None:
        """Write the newest pose handed over, until none is left (on the I2C thread)."""
        while True:
            with self._slot:
                pose, self._latest = self._latest, None
                if pose is None:
                    self._writing = False
                    return
            try:
                self._write_block(pose)
            except OSError as exc:
                with self._slot:
                    self._latest, self._writing = None, False
                self._close_bus()
                raise self._no_answer(exc) from None

    def _write_block(self, pose: Mapping[int, int]) -> None:
        assert self._bus is not None
        block = reg.pose_block(self.map.checked(pose))
        self._bus.i2c_rdwr(self._smbus2.i2c_msg.write(self.address, block))

    def _park(self) -> None:
        assert self._bus is not None
        try:
            self._write_block(self.map.neutral_pose())
            time.sleep(self.config.exit_hold_s)
            mode1 = self._bus.read_byte_data(self.address, reg.MODE1)
            self._bus.write_byte_data(self.address, reg.MODE1, (mode1 & ~reg.RESTART) | reg.SLEEP)
        except OSError as exc:
            raise self._no_answer(exc) from None

    def _read_status(self) -> dict[str, Any]:
        assert self._bus is not None
        bus, address = self._bus, self.address
        try:
            mode1 = bus.read_byte_data(address, reg.MODE1)
            mode2 = bus.read_byte_data(address, reg.MODE2)
            prescale = bus.read_byte_data(address, reg.PRE_SCALE)
            widths = {}
            tick = reg.tick_us(prescale, self.config.oscillator_hz)
            for ch, lim in sorted(self.map.limits.items()):
                base = reg.channel_register(ch)
                raw = [bus.read_byte_data(address, base + i) for i in range(reg.CHANNEL_BYTES)]
                widths[lim.name] = reg.pulse_ticks(bytes(raw)) * tick
        except OSError as exc:
            raise self._no_answer(exc) from None
        return {
            "bus": self.path,
            "address": f"0x{address:02x}",
            "mode1": f"0x{mode1:02x}" + (" (asleep)" if mode1 & reg.SLEEP else ""),
            "mode2": f"0x{mode2:02x}",
            "prescale": prescale,
            "frequency_hz": round(self.config.oscillator_hz / (reg.TICKS * (prescale + 1)), 3),
            "pulses_us": widths,
        }

    def _no_answer(self, exc: OSError) -> DeviceUnavailable:
        what = "no device answers" if exc.errno in (errnos.EREMOTEIO, errnos.ENXIO) else "error"
        return DeviceUnavailable(f"{self.path}: {what} at 0x{self.address:02x} ({_reason(exc)})")

    def _close_bus(self) -> None:
        bus, self._bus = self._bus, None
        if bus is not None:
            with contextlib.suppress(OSError):
                bus.close()
