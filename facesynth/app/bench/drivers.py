"""``facesynth bench drivers``: what one pose costs on the wire with each servo driver.

Every figure comes from the drivers' own encoders: the bytes of one pose of the profile (every
servo at a different four-digit width), the answer the board sends back, the time those bytes
take on the wire at the driver's baud rate (8N1: 10 bits per byte), how many poses per second
the line carries, and the CPU time to encode one pose (median of many).
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass

from facesynth.runtime.profiles import Profile, load_profile
from facesynth.services.control.drivers.arduino import protocol as arduino
from facesynth.services.control.drivers.arduino.driver import pose_frame
from facesynth.services.control.drivers.bus_servo.budget import wire_s
from facesynth.services.control.drivers.maestro import protocol as maestro
from facesynth.services.control.drivers.ssc32 import protocol as ssc32


@dataclass(frozen=True)
class WireCost:
    """One way of sending a pose."""

    driver: str
    how: str
    baud: int
    frame_bytes: int
    reply_bytes: int
    encode_us: float

    @property
    def wire_ms(self) -> float:
        """Milliseconds the pose takes on the wire (to the board)."""
        return wire_s(self.frame_bytes, self.baud) * 1000

    @property
    def poses_per_s(self) -> float:
        """Poses per second the line carries (the longer direction counts)."""
        return 1 / wire_s(max(self.frame_bytes, self.reply_bytes), self.baud)


def median_us(encode: Callable[[], object], repeat: int = 2000, rounds: int = 9) -> float:
    """Microseconds one call of ``encode`` takes: the median of ``rounds`` rounds of ``repeat``."""
    times = []
    for _ in range(rounds):
        start = time.perf_counter_ns()
        for _ in range(repeat):
            encode()
        times.append((time.perf_counter_ns() - start) / repeat / 1000)
    return statistics.median(times)


def sample_pose(profile: Profile) -> dict[int, float]:
    """Every servo somewhere different inside its limits (µs by channel)."""
    count = len(profile.servos)
    return {
        spec.channel: spec.min_us + (spec.max_us - spec.min_us) * (0.2 + 0.6 * i / max(1, count))
        for i, spec in enumerate(profile.servos)
    }


def wire_costs(profile: Profile) -> list[WireCost]:
    """The pose of :func:`sample_pose` through each driver's encoder."""
    us = {ch: round(v) for ch, v in sample_pose(profile).items()}
    quarter = {ch: round(v * 4) for ch, v in sample_pose(profile).items()}
    speeds = {s.channel: round(s.max_speed) for s in profile.servos if s.max_speed > 0}
    channels = max(len(us), max(us) + 1)
    ack = arduino.FRAME_OVERHEAD + arduino.REPLIES[0x80].size
    cases: list[tuple[str, str, int, int, Callable[[], bytes]]] = [
        ("arduino", "SET_ALL, CRC, ACK back", 115200, ack, lambda: pose_frame(1, us, channels)),
        (
            "maestro",
            "Mini: Set Multiple Targets",
            115200,
            0,
            lambda: maestro.targets(quarter, True),
        ),
        (
            "maestro",
            "Micro/auto: Set Target each",
            115200,
            0,
            lambda: maestro.targets(quarter, False),
        ),
        ("ssc32", "group move", 115200, 0, lambda: ssc32.group_move(us)),
        ("ssc32", "group move, S per servo", 115200, 0, lambda: ssc32.group_move(us, speeds)),
        ("ssc32", "group move, S, factory 9600", 9600, 0, lambda: ssc32.group_move(us, speeds)),
    ]
    return [
        WireCost(driver, how, baud, len(encode()), reply, median_us(encode))
        for driver, how, baud, reply, encode in cases
    ]


def bench_drivers(profile_name: str = "paper16") -> tuple[Profile, list[WireCost]]:
    """The profile and its wire costs."""
    profile = load_profile(profile_name)
    return profile, wire_costs(profile)


def format_drivers(profile: Profile, costs: list[WireCost]) -> str:
    """A side-by-side table."""
    lines = [
        f"one pose of profile {profile.name} ({len(profile.servos)} servos), per driver",
        f"{'driver':<8} {'how':<28} {'baud':>6} {'bytes':>5} {'back':>4} {'wire ms':>8} "
        f"{'poses/s':>8} {'encode us':>9}",
    ]
    for c in costs:
        lines.append(
            f"{c.driver:<8} {c.how:<28} {c.baud:>6} {c.frame_bytes:>5} {c.reply_bytes:>4} "
            f"{c.wire_ms:>8.2f} {c.poses_per_s:>8.0f} {c.encode_us:>9.1f}"
        )
    lines.append(
        "(8N1: 10 bits per byte. A Maestro on its USB port ignores the baud rate; facesynth "
        "sends 24-60 poses/s.)"
    )
    return "\n".join(lines)
