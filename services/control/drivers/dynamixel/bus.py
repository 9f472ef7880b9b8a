"""A Dynamixel bus through ROBOTIS's ``dynamixel_sdk`` (Protocol 2.0 or 1.0), on the bus thread.

Poses go out as one ``GroupSyncWrite`` of Goal Position. The read-back is one Sync Read of
the X series block (Protocol 2.0: the SDK's ``syncReadTx``, then each servo's status packet
through the SDK's ``rxPacket``, which checks the CRC and removes the stuffing; a missing or
garbled answer leaves that servo out, not the others) or one READ per servo (Protocol 1.0,
whose AX servos have no Sync Read). A status packet with the Alert bit makes the bus read
that servo's Hardware Error Status.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from services.control.drivers.bus_servo.bus import Ping, ServoBus, Status
from services.control.drivers.bus_servo.native import Model, NativeServo
from services.control.drivers.dynamixel import models as m


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
        size = 4 if self.protocol == 2 else 2
        group = self.sdk.GroupSyncWrite(
            self.port, self.ph, m.X_GOAL if size == 4 else m.P1_GOAL, size
        )
        for servo_id, goal in sorted(goals.items()):
            group.addParam(servo_id, list(int(goal).to_bytes(size, "little", signed=True)))
        result = group.txPacket()
        if result != self.sdk.COMM_SUCCESS:
            raise OSError(f"Sync Write not sent: {self.ph.getTxRxResult(result)}")
        return self.write_bytes(len(goals))

    def read(self, ids: Sequence[int]) -> dict[int, Status | None]:
        if self.protocol == 1:
            return {i: self._read_p1(i) for i in ids}
        out: dict[int, Status | None] = dict.fromkeys(ids)
        result = self.ph.syncReadTx(self.port, m.X_READ, m.X_READ_SIZE, list(ids), len(ids), False)
        if result != self.sdk.COMM_SUCCESS:
            raise OSError(f"Sync Read not sent: {self.ph.getTxRxResult(result)}")
        waiting = set(ids)
        errors: dict[int, int] = {}
        for _ in range(len(ids) + 4):
            packet, result = self.ph.rxPacket(self.port, False)
            if result == self.sdk.COMM_RX_TIMEOUT:
                break
            parsed = (
                m.parse_status2(packet, m.X_READ_SIZE) if result == self.sdk.COMM_SUCCESS else None
            )
            if parsed is None or parsed[0] not in waiting:
                self.garbled += 1
                continue
            servo_id, errors[servo_id], data = parsed
            waiting.discard(servo_id)
            out[servo_id] = m.decode_x(data)
            if not waiting:
                break
        for servo_id, error in errors.items():  # after the answers: a read clears the port
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
        data, result, error = self.ph.readTxRx(self.port, servo_id, m.P1_READ, m.P1_READ_SIZE)
        if result != self.sdk.COMM_SUCCESS:
            return None
        try:
            return m.decode_p1(bytes(data), error)
        except ValueError:
            self.garbled += 1
            return None

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
