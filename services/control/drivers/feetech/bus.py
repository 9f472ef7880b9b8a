"""A Feetech bus through Feetech's ``scservo_sdk`` (STS and SCS servos), on the bus thread.

Packets are ``FF FF ID LEN INST … CHK``. The SDK opens the port, asks the models, configures
and relaxes the servos; the per-frame packets are built and parsed by :mod:`..bus_servo.wire`
(the SDK's cost a frame was most of the control process's CPU): each pose goes out as one Sync
Write of Goal Position, and the read-back is one Sync Read (every status packet's checksum
checked) when every servo read is an STS, one READ per servo otherwise. Words are packed here
in each servo's byte order: the SDK's own word helpers follow one process-wide setting, which
a bus of both series breaks.
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
from facesynth.services.control.drivers.feetech import models as m


class FeetechBus(ServoBus):
    """STS and SCS servos on one port (``sdk`` is the ``scservo_sdk`` module)."""

    name = "Feetech"

    def __init__(self, sdk: Any, port: str, baud: int, *, latency_ms: float) -> None:
        super().__init__(sdk, port, baud, latency_ms)
        self.ph = sdk.PacketHandler(m.STS)
        self.series: dict[int, int] = {}  # id -> byte order, from its model

    def model(self, number: int) -> Model | None:
        return m.MODELS.get(number)

    def ping(self, servo_id: int) -> Ping | None:
        data, result, error = self.ph.readTxRx(self.port, servo_id, m.MODEL_ADDR, 2)
        if result != self.sdk.COMM_SUCCESS or len(data) != 2:
            return None
        number = m.model_from_bytes(bytes(data))
        model = m.MODELS.get(number)
        if model is not None:
            self.series[servo_id] = model.protocol
        return Ping(number, m.hardware_errors(error))

    def read_hz(self, ids: Sequence[int]) -> float:
        return READ_EACH_HZ if any(self.series.get(i) == m.SCS for i in ids) else SYNC_READ_HZ

    def prepare(self, servo: NativeServo, speed: float, accel: float) -> None:
        i, series = servo.bus_id, servo.model.protocol
        self.series[i] = series
        velocity = _units(servo.units_per_s(speed), m.SPEED_UNIT, m.SPEED_LIMIT)
        if series == m.STS:
            self._write(
                i, m.ACCEL, bytes((_units(servo.units_per_s(accel), m.ACCEL_UNIT, m.ACCEL_LIMIT),))
            )
        self._write(i, m.SPEED, m.word(velocity, series))
        self._write(i, m.TORQUE, b"\x01")

    def write_goals(self, goals: Mapping[int, int]) -> int:
        if not goals:
            return 0
        words = [
            (servo_id, m.wire_word(goal, self.series.get(servo_id, m.STS)))
            for servo_id, goal in sorted(goals.items())
        ]
        packet = wire.sync_write1(m.GOAL, 2, words)
        self.send(packet)
        return len(packet)

    def read(self, ids: Sequence[int]) -> dict[int, Status | None]:
        if any(self.series.get(i) == m.SCS for i in ids):
            return {i: self._read_one(i) for i in ids}
        out: dict[int, Status | None] = dict.fromkeys(ids)
        asked = tuple(ids)
        got = self.transact(
            wire.sync_read1(m.READ, m.READ_SIZE, asked),
            (6 + m.READ_SIZE) * len(asked),
            wire.take_status1,
            asked,
            m.READ_SIZE,
        )
        for servo_id, (error, data) in got.items():
            out[servo_id] = m.decode(data, error, m.STS)
        return out

    def relax(self, ids: Sequence[int]) -> None:
        for servo_id in ids:
            self.ph.writeTxRx(self.port, servo_id, m.TORQUE, 1, [0])

    def write_bytes(self, count: int) -> int:
        return 8 + count * 3  # FF FF FE LEN INST address length … checksum; id + 2 each

    def read_bytes(self, count: int) -> int:
        if any(s == m.SCS for s in self.series.values()):
            return count * (8 + 6 + m.READ_SIZE)
        return 8 + count + count * (6 + m.READ_SIZE)

    def _read_one(self, servo_id: int) -> Status | None:
        got = self.transact(
            wire.read1(servo_id, m.READ, m.READ_SIZE),
            6 + m.READ_SIZE,
            wire.take_status1,
            (servo_id,),
            m.READ_SIZE,
        )
        if servo_id not in got:
            return None
        error, data = got[servo_id]
        return m.decode(data, error, self.series.get(servo_id, m.STS))

    def _write(self, servo_id: int, address: int, data: bytes) -> None:
        for _ in range(3):  # a lost confirmation: write again (it is idempotent)
            result, _ = self.ph.writeTxRx(self.port, servo_id, address, len(data), list(data))
            if result == self.sdk.COMM_SUCCESS:
                break
        if result != self.sdk.COMM_SUCCESS:
            raise TimeoutError(f"id {servo_id} did not confirm a write to {address}")


def _units(native_per_s: float, unit: float, limit: int) -> int:
    """A speed in the servo's units: 0 stays 0 (no limit), others 1..``limit``."""
    if native_per_s <= 0 or not math.isfinite(native_per_s):
        return 0
    return max(1, min(limit, round(native_per_s / unit)))
