"""A Dynamixel bus through ROBOTIS's ``dynamixel_sdk`` (Protocol 2.0 or 1.0), on the bus thread.

The SDK opens the port, pings, configures and relaxes the servos. The per-frame packets are
built and parsed by :mod:`..bus_servo.wire` (the SDK's cost a frame was most of the control
process's CPU): each pose goes out as one Sync Write of Goal Position, and the read-back is one
Sync Read of the X series block (Protocol 2.0: every status packet's CRC checked and its
stuffing removed; a missing or garbled answer leaves that servo out, not the others) or one
READ per servo (Protocol 1.0, whose AX servos have no Sync Read). A status packet with the
Alert bit makes the bus read that servo's Hardware Error Status (through the SDK).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from facesynth.services.control.drivers.bus_servo import wire
from facesynth.services.control.drivers.bus_servo.bus import (
    READ_EACH_HZ,
    SYNC_READ_HZ,
    Ping,
    ServoBus,
    Status,
)
from facesynth.services.control.drivers.bus_servo.native import Model, NativeServo
from facesynth.services.control.drivers.dynamixel import models as m


class DynamixelBus(ServoBus):
    """Servos of one protocol on one port (``sdk`` is the ``dynamixel_sdk`` module)."""

    def __init__(self, sdk: Any, port: str, baud: int, *, protocol: int, latency_ms: float) -> None:
        super().__init__(sdk, port, baud, latency_ms)
        self.protocol = protocol
        self.name = f"Dynamixel Protocol {protocol}.0"
        self.ph = sdk.PacketHandler(float(protocol))

    def model(self, number: int) -> Model | None:
        found = m.MODELS.get(number)
        return found if found is not None and found.protocol == self.protocol else None

    def ping(self, servo_id: int) -> Ping | None:
        number, result, error = self.ph.ping(self.port, servo_id)
        if result != self.sdk.COMM_SUCCESS:
            return None
        return Ping(number, self._fault(servo_id, error))

    def read_hz(self, ids: Sequence[int]) -> float:
        return READ_EACH_HZ if self.protocol == 1 else SYNC_READ_HZ

    def scan(self) -> dict[int, int]:
        """Every servo on the bus by one broadcast ping (Protocol 2.0; 1.0 has none)."""
        if self.protocol != 2:
            return {}
        found, _ = self.ph.broadcastPing(self.port)
        return {int(i): int(v[0]) for i, v in found.items()}

    def prepare(self, servo: NativeServo, speed: float, accel: float) -> None:
        i = servo.bus_id
        if self.protocol == 2:
            velocity = _units(servo.units_per_s(speed), m.X_VELOCITY_UNIT, m.X_LIMIT)
            acceleration = _units(servo.units_per_s(accel), m.X_ACCEL_UNIT, m.X_LIMIT)
            self._write(i, m.X_ACCEL, 4, acceleration)
            self._write(i, m.X_VELOCITY, 4, velocity)
            self._write(i, m.X_TORQUE, 1, 1)
            return
        self._write(
            i, m.P1_SPEED, 2, _units(servo.units_per_s(speed), m.p1_speed_unit(servo.model), 1023)
        )
        if servo.model.name.startswith("MX"):
            unit = 8.583 * servo.model.units_per_degree
            self._write(i, m.P1_ACCEL, 1, _units(servo.units_per_s(accel), unit, 254))
        self._write(i, m.P1_TORQUE, 1, 1)

    def write_goals(self, goals: Mapping[int, int]) -> int:
        if not goals:
            return 0
        items = sorted(goals.items())
        if self.protocol == 2:
            packet = wire.sync_write2(m.X_GOAL, 4, items)
        else:
            packet = wire.sync_write1(m.P1_GOAL, 2, [(i, goal & 0xFFFF) for i, goal in items])
        self.send(packet)
        return len(packet)

    def read(self, ids: Sequence[int]) -> dict[int, Status | None]:
        if self.protocol == 1:
            return {i: self._read_p1(i) for i in ids}
        out: dict[int, Status | None] = dict.fromkeys(ids)
        asked = tuple(ids)
        got = self.transact(
            wire.sync_read2(m.X_READ, m.X_READ_SIZE, asked),
            (11 + m.X_READ_SIZE) * len(asked),
            wire.take_status2,
            asked,
            m.X_READ_SIZE,
        )
        for servo_id, (_, data) in got.items():
            out[servo_id] = m.decode_x(data)
        for servo_id, (error, _) in got.items():  # after the answers: a read clears the port
            status = out[servo_id]
            if error & m.ALERT and status is not None:
                fault = self._fault(servo_id, error)
                out[servo_id] = Status(status.position, status.load, status.temperature_c, fault)
        return out

    def relax(self, ids: Sequence[int]) -> None:
        address = m.X_TORQUE if self.protocol == 2 else m.P1_TORQUE
        for servo_id in ids:
            self.ph.write1ByteTxRx(self.port, servo_id, address, 0)

    def write_bytes(self, count: int) -> int:
        if self.protocol == 2:
            return 14 + count * 5  # header 7, INST, address 2, length 2, CRC 2; id + 4 each
        return 8 + count * 3  # FF FF id len INST address length … checksum; id + 2 each

    def read_bytes(self, count: int) -> int:
        if self.protocol == 2:
            return 14 + count + count * (11 + m.X_READ_SIZE)
        return count * (8 + 6 + m.P1_READ_SIZE)

    # -- internals -----------------------------------------------------------------------------

    def _read_p1(self, servo_id: int) -> Status | None:
        got = self.transact(
            wire.read1(servo_id, m.P1_READ, m.P1_READ_SIZE),
            6 + m.P1_READ_SIZE,
            wire.take_status1,
            (servo_id,),
            m.P1_READ_SIZE,
        )
        if servo_id not in got:
            return None
        error, data = got[servo_id]
        return m.decode_p1(data, error)

    def _fault(self, servo_id: int, error: int) -> str:
        if self.protocol == 1:
            return m.hardware_errors(error, m.P1_HW_ERRORS)
        if not error & m.ALERT:
            return ""
        bits, result, _ = self.ph.read1ByteTxRx(self.port, servo_id, m.X_HW_ERROR)
        if result != self.sdk.COMM_SUCCESS:
            return "hardware error (status not readable)"
        return m.hardware_errors(bits, m.HW_ERRORS) or f"hardware error 0x{bits:02x}"

    def _write(self, servo_id: int, address: int, size: int, value: int) -> None:
        write = {1: self.ph.write1ByteTxRx, 2: self.ph.write2ByteTxRx, 4: self.ph.write4ByteTxRx}
        for _ in range(3):  # a lost or garbled confirmation: write again (it is idempotent)
            result, error = write[size](self.port, servo_id, address, value)
            if result == self.sdk.COMM_SUCCESS:
                break
        if result != self.sdk.COMM_SUCCESS:
            raise TimeoutError(f"id {servo_id} did not confirm a write to {address}")
        if error & 0x7F:
            raise OSError(
                f"id {servo_id} refused {value} at address {address}: "
                f"{self.ph.getRxPacketError(error)}"
            )


def _units(native_per_s: float, unit: float, limit: int) -> int:
    """A speed in the servo's units: 0 stays 0 (no limit), others at least 1, at most
    ``limit``."""
    if native_per_s <= 0 or not math.isfinite(native_per_s):
        return 0
    return max(1, min(limit, round(native_per_s / unit)))
