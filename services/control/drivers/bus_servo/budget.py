"""Bus time from bytes: how long a frame's Sync Write and read-back keep a servo bus busy.

A UART byte is 10 bits on the wire (8N1). The figures leave out each servo's return delay
(Dynamixel X series ship with 500 µs per answer: set Return Delay Time to 0 for a head) and
the USB adapter's latency, which are waits, not bytes.
"""

from __future__ import annotations

from collections.abc import Callable

BITS_PER_BYTE = 10


def wire_s(count: int, baud: int) -> float:
    """Seconds ``count`` bytes take at ``baud``."""
    return count * BITS_PER_BYTE / baud


def read_chunk(read_bytes: Callable[[int], int], servos: int, baud: int, budget_s: float) -> int:
    """How many servos one read-back may cover within ``budget_s`` of bus time (at least one,
    at most ``servos``); ``read_bytes(n)`` is the bytes of a read-back of n servos."""
    fits = 1
    for count in range(1, servos + 1):
        if wire_s(read_bytes(count), baud) > budget_s:
            break
        fits = count
    return fits
