"""``facesynth bench drivers``, smart servo buses: a frame's bus time from the bytes.

For the ``dynamixel`` and ``feetech`` drivers a frame is one Sync Write of every servo's goal
and a read-back of as many servos as fit in the driver's read budget (default 2 ms). The
Sync Write is the bytes the driver writes (captured from its port; built by
``bus_servo/wire.py``, the SDKs' own packets byte for byte), the read request the bytes the
vendor's SDK writes; the answers are the status packets the protocol defines (Dynamixel 2.0:
11 bytes + data each; 1.0 and Feetech: 6 + data). 8N1: 10 bits per byte. ``encode us`` is
the CPU time of building and writing the Sync Write (the control process's cost per frame).
The frames measured on the emulated buses, and C's CPU per frame: ``--emulated``
(:mod:`.driver_cpu`).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any

from facesynth.app.bench.drivers import median_us
from facesynth.runtime.profiles import Profile
from facesynth.services.control.drivers.bus_servo.budget import read_chunk, wire_s
from facesynth.services.control.drivers.bus_servo.bus import ServoBus
from facesynth.services.control.drivers.bus_servo.native import Model

READ_BUDGET_S = 0.002
FRAME_MS = 1000 / 30
GOAL_MS = 3.0


class CapturePort:
    """The SDK port of the bench: keeps what the SDK writes, answers nothing."""

    def __init__(self) -> None:
        self.written = bytearray()
        self.is_using = False
        self.baudrate = 1000000

    def clearPort(self) -> None:  # the SDK's name
        pass

    def writePort(self, packet: Any) -> int:
        self.written += bytes(packet)
        return len(packet)

    def setPacketTimeout(self, _: int) -> None:
        pass


@dataclass(frozen=True)
class BusFrame:
    """One frame on a smart servo bus."""

    driver: str
    how: str
    baud: int
    write_bytes: int
    request_bytes: int
    answer_bytes: int
    servos_read: int
    encode_us: float

    @property
    def bus_ms(self) -> float:
        """Bus time of the frame: Sync Write, read request and the answers."""
        total = self.write_bytes + self.request_bytes + self.answer_bytes
        return wire_s(total, self.baud) * 1000


def _frame(
    driver: str, how: str, bus: ServoBus, model: Model, count: int, baud: int, status: int
) -> BusFrame:
    port = CapturePort()
    bus.port = port
    if hasattr(bus, "series"):  # feetech: each servo's byte order
        bus.series = dict.fromkeys(range(1, count + 1), model.protocol)
    goals = {i: model.centre + 7 * i for i in range(1, count + 1)}

    def write_goals() -> None:
        port.written.clear()
        bus.write_goals(goals)

    encode_us = median_us(write_goals, repeat=200, rounds=7)
    write = len(port.written)
    chunk = read_chunk(bus.read_bytes, count, baud, READ_BUDGET_S)
    port.written.clear()
    ids = list(range(1, chunk + 1))
    ph: Any = bus.ph  # type: ignore[attr-defined]
    if driver == "dynamixel" and model.protocol == 2:
        ph.syncReadTx(port, 126, 21, ids, len(ids), False)
        request, answers = len(port.written), chunk * (11 + status)
    elif driver == "feetech" and model.protocol == 0:
        ph.syncReadTx(port, 56, status, ids, len(ids))
        request, answers = len(port.written), chunk * (6 + status)
    else:  # one READ per servo
        for i in ids:
            port.is_using = False  # (the SDK frees the port once the answer is read)
            ph.readTx(port, i, 36 if driver == "dynamixel" else 56, status)
        request, answers = len(port.written), chunk * (6 + status)
    return BusFrame(driver, how, baud, write, request, answers, chunk, encode_us)


def bus_frames(profile: Profile) -> list[BusFrame]:
    """A frame of ``profile``'s servo count on each bus driver the installed SDKs allow."""
    count = len(profile.servos)
    frames: list[BusFrame] = []
    try:
        sdk = importlib.import_module("dynamixel_sdk")
    except ImportError:
        sdk = None
    if sdk is not None:
        from facesynth.services.control.drivers.dynamixel.bus import DynamixelBus
        from facesynth.services.control.drivers.dynamixel.models import BY_NAME

        for how, model, baud, size in (
            ("2.0 XL430, Sync Read", BY_NAME["xl430-w250"], 1000000, 21),
            ("2.0 XL430, factory 57600", BY_NAME["xl430-w250"], 57600, 21),
            ("1.0 AX-12A, READ each", BY_NAME["ax-12a"], 1000000, 8),
        ):
            bus = DynamixelBus(sdk, "bench", baud, protocol=model.protocol, latency_ms=0)
            frames.append(_frame("dynamixel", how, bus, model, count, baud, size))
    try:
        scs = importlib.import_module("scservo_sdk")
    except ImportError:
        scs = None
    if scs is not None:
        from facesynth.services.control.drivers.feetech.bus import FeetechBus
        from facesynth.services.control.drivers.feetech.models import BY_NAME as FEETECH

        for how, model in (
            ("STS3215, Sync Read", FEETECH["sts3215"]),
            ("SCS0009, READ each", FEETECH["scs0009"]),
        ):
            feetech = FeetechBus(scs, "bench", 1000000, latency_ms=0)
            frames.append(_frame("feetech", how, feetech, model, count, 1000000, 8))
    return frames


def format_bus_frames(profile: Profile, frames: list[BusFrame]) -> str:
    """The smart bus table, under the drivers' table."""
    lines = [
        "",
        f"smart servo buses: one frame of {len(profile.servos)} servos = one Sync Write and a "
        f"read-back within {READ_BUDGET_S * 1000:g} ms (--bus-read-ms), goal <= {GOAL_MS:g} ms "
        "at 1 Mbps",
        f"{'driver':<9} {'how':<26} {'baud':>7} {'write':>5} {'ask':>4} {'answers':>7} "
        f"{'read':>4} {'bus ms':>7} {'of frame':>8} {'encode us':>9}",
    ]
    for f in frames:
        lines.append(
            f"{f.driver:<9} {f.how:<26} {f.baud:>7} {f.write_bytes:>5} {f.request_bytes:>4} "
            f"{f.answer_bytes:>7} {f.servos_read:>4} {f.bus_ms:>7.2f} "
            f"{f.bus_ms / FRAME_MS:>7.0%} {f.encode_us:>9.1f}"
        )
    if not frames:
        lines.append("(neither dynamixel-sdk nor feetech-servo-sdk is installed)")
    else:
        lines.append(
            "(read: servos read back per frame, in turn; the answers exclude each servo's "
            "return delay: set it to 0)"
        )
    return "\n".join(lines)
