"""The async side of a smart servo bus driver: the pose it holds, handed to the bus thread.

:meth:`send` checks and clamps the positions (µs by name) and hands the pose to the
:class:`~facesynth.services.control.drivers.bus_servo.worker.BusWorker`, which writes it as one Sync
Write; nothing here waits on the bus. :meth:`readings` returns the latest read-back.
At :meth:`close` the pending pose (the control service's neutral) is written first, then the
torque stays on (``at_exit = "hold"``, the default: the face keeps its neutral) or is turned
off (``"relax"``).
"""

from __future__ import annotations

import abc
import asyncio
import logging
import math
from collections.abc import Mapping
from typing import Any, Literal

from facesynth.runtime.profiles import Profile
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.base import (
    DeviceUnavailable,
    FoundDevice,
    ServoDriver,
    ServoReading,
)
from facesynth.services.control.drivers.bus_servo.budget import read_chunk, wire_s
from facesynth.services.control.drivers.bus_servo.bus import ServoBus
from facesynth.services.control.drivers.bus_servo.native import NativePose
from facesynth.services.control.drivers.bus_servo.worker import BusWorker

AtExit = Literal["hold", "relax"]
AT_EXIT_HELP = (
    "at shutdown, after the neutral face: hold it with the torque on (default) or relax "
    "(torque off, the face goes limp)"
)
READ_BUDGET_HELP = (
    "bus time (ms) one read-back of present position/load/temperature may take; as many "
    "servos as fit are read each time, in turn"
)
READ_HZ_HELP = (
    "read-backs per second, each after a pose's Sync Write (or on its own when no pose "
    "comes); default 15 with Sync Read, 5 where each servo is read on its own (Dynamixel "
    "1.0, Feetech SCS); more read positions sooner and cost C more CPU"
)
LATENCY_HELP = (
    "the USB adapter's latency timer in ms, for the answer timeouts (FTDI default 16; "
    "1 after setting /sys/bus/usb-serial/devices/ttyUSB0/latency_timer; 0 on a pty)"
)


class BusServoDriver(ServoDriver):
    """A smart servo bus; subclasses make the vendor's :class:`ServoBus`."""

    #: The bus's name in messages.
    board = "servo bus"

    def __init__(
        self,
        profile: Profile,
        *,
        port: str,
        baud: int,
        read_budget_ms: float,
        read_hz: float | None,
        at_exit: AtExit,
        log: logging.Logger,
    ) -> None:
        self.profile = profile
        self.port = port
        self.baud = baud
        self.read_budget_s = read_budget_ms / 1000
        self.read_hz = read_hz
        self.at_exit = at_exit
        self.log = log
        self.map = NativePose(profile)
        self.pose_us: dict[str, float] = profile.neutral_positions()
        self.worker: BusWorker | None = None
        # The readings built from the worker's statuses at one version (worker, version, them).
        self._readings: tuple[BusWorker, int, dict[str, ServoReading]] | None = None
        self._state: tuple[tuple[Any, ...], str] | None = None

    @abc.abstractmethod
    def make_bus(self) -> ServoBus:
        """A new bus object (the vendor's SDK, port closed) for one connection."""

    def limits(self) -> dict[int, tuple[float, float]]:
        """Each servo's max_speed (µs/s) and max_accel (µs/s²) by bus id."""
        return {self.map.ids[s.name]: (s.max_speed, s.max_accel) for s in self.profile.servos}

    async def connect(self) -> None:
        """Open the bus; a bus not there yet (or silent) is waited for in the background."""
        await self._start(retry=True, query_only=False)

    async def connect_once(self, *, query_only: bool = False) -> None:
        """Open the bus now or raise :class:`DeviceUnavailable`; ``query_only`` pings and
        reads but neither configures nor moves the servos."""
        await self._start(retry=False, query_only=query_only)

    async def _start(self, *, retry: bool, query_only: bool) -> None:
        if self.worker is not None:
            await self.close()
        worker = BusWorker(
            self.make_bus(),
            self.map,
            port=self.port,
            baud=self.baud,
            limits=self.limits(),
            read_budget_s=self.read_budget_s,
            read_period_s=1 / self.read_hz if self.read_hz else None,
            log=self.log,
        )
        worker.query_only = query_only
        self.worker = worker
        try:
            await asyncio.wrap_future(worker.start(self.pose_us, retry=retry))
        except BaseException:
            self.worker = None
            await asyncio.to_thread(worker.stop, relax=False)
            raise

    async def send(self, positions: Mapping[str, float], info: CommandInfo) -> None:
        """Hold the pose and hand it to the bus thread (never waits on the bus)."""
        checked = self.map.checked_us(positions)
        if self.worker is None:
            raise DeviceUnavailable(f"{self.port}: not connected")
        self.pose_us.update(checked)
        self.worker.submit(self.pose_us)

    async def close(self) -> None:
        """Write the pending pose, hold or relax (``at_exit``), close the port."""
        worker, self.worker = self.worker, None
        if worker is not None:
            await asyncio.to_thread(worker.stop, relax=self.at_exit == "relax")

    def readings(self) -> Mapping[str, ServoReading]:
        """The latest read-back of each servo (position in µs; NaN until first read)."""
        worker = self.worker
        if worker is None or not self.map.servos:
            return {}
        version = worker.version  # before the snapshot: a newer one is built again next time
        cached = self._readings
        if cached is not None and cached[0] is worker and cached[1] == version:
            return cached[2]
        statuses, faults = worker.snapshot()
        out = {}
        for name, servo_id in self.map.ids.items():
            status = statuses.get(servo_id)
            fault = faults.get(servo_id, "")
            if status is None and not fault:
                continue
            servo = self.map.servos[servo_id]
            out[name] = ServoReading(
                position_us=servo.us(status.position) if status else math.nan,
                load=status.load if status else None,
                temperature_c=status.temperature_c if status else None,
                fault=fault,
            )
        self._readings = (worker, version, out)
        return out

    def state(self) -> str:
        """The bus's state, the models found and the faults."""
        worker = self.worker
        if worker is None:
            return f"not connected to {self.port}"
        link = worker.state
        key = (
            worker,
            worker.version,
            link.connected,
            link.connects,
            link.failed_attempts,
            link.last_error,
            link.writes_dropped,
            worker.overtaken,
            len(worker.found),
        )
        if self._state is not None and self._state[0] == key:
            return self._state[1]  # (asked every frame; it changes far less often)
        parts = [worker.state.describe()]
        if worker.found:
            names = sorted({model.name for model in worker.found.values()})
            parts.append(f"{len(worker.found)} servos ({', '.join(names)}) at {self.baud} baud")
        if worker.overtaken:
            parts.append(f"{worker.overtaken} poses overtaken while the bus was busy")
        _, faults = worker.snapshot()
        if faults:
            parts.append(
                "faults: " + ", ".join(f"id {i} {text}" for i, text in sorted(faults.items()))
            )
        self._state = (key, "; ".join(parts))
        return self._state[1]

    def frame_bus_ms(self) -> tuple[float, float, int]:
        """Bus time of a frame from its bytes: Sync Write ms, read-back ms, servos read."""
        bus = self.make_bus()
        count = len(self.profile.servos)
        chunk = read_chunk(bus.read_bytes, count, self.baud, self.read_budget_s)
        return (
            wire_s(bus.write_bytes(count), self.baud) * 1000,
            wire_s(bus.read_bytes(chunk), self.baud) * 1000,
            chunk,
        )

    async def found(self) -> list[FoundDevice]:
        """The profile's ids (model, or why it cannot serve its servo) and, on a bus that can
        be asked all at once, every other id that answers; read only."""
        worker = self.worker
        if worker is None or not worker.state.connected:
            raise DeviceUnavailable(f"{self.port}: not connected")
        scanned = await asyncio.wrap_future(worker.call(lambda bus: bus.scan()))
        bus = worker.bus
        devices = []
        for name, servo_id in sorted(self.map.ids.items(), key=lambda item: item[1]):
            ping = worker.answers.get(servo_id)
            model = bus.model(ping.model_number) if ping else None
            text = (
                "no answer"
                if ping is None
                else model.name
                if model
                else f"model number {ping.model_number}"
            )
            problem = worker.problems.get(servo_id, "") or (ping.fault if ping else "")
            devices.append(FoundDevice(f"id {servo_id}", text, name, problem))
        for servo_id, number in sorted(scanned.items()):
            if servo_id not in worker.answers:
                model = bus.model(number)
                devices.append(
                    FoundDevice(f"id {servo_id}", model.name if model else f"model number {number}")
                )
        return devices

    async def device_status(self) -> dict[str, Any]:
        """Ids and models found, and a read-back of every servo."""
        worker = self.worker
        if worker is None or not worker.state.connected:
            raise DeviceUnavailable(f"{self.port}: not connected")
        ids = sorted(self.map.servos)
        statuses = await asyncio.wrap_future(worker.call(lambda bus: bus.read(ids)))
        by_id = {i: n for n, i in self.map.ids.items()}
        servos = {}
        for servo_id in ids:
            status = statuses.get(servo_id)
            model = worker.found[servo_id]
            servos[by_id[servo_id]] = {
                "id": servo_id,
                "model": model.name,
                "position_us": round(self.map.servos[servo_id].us(status.position), 1)
                if status
                else None,
                "load": status.load if status else None,
                "temperature_c": status.temperature_c if status else None,
                "fault": (status.fault if status else "not answering") or "none",
            }
        for servo_id, problem in sorted(worker.problems.items()):  # cannot serve the profile
            servos[by_id[servo_id]] = {"id": servo_id, "problem": problem}
        return {"port": self.port, "baud": self.baud, "servos": servos}
