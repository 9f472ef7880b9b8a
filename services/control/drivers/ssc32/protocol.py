"""Lynxmotion SSC-32 / SSC-32U ASCII protocol: group moves and the queries facesynth uses.

From the SSC-32U User Guide, "Commands": ``#<ch>P<pw>[S<spd>]`` for each servo, optionally
``T<time>`` for the whole group, then a carriage return; everything in one line starts and
ends together. Channels 0..31, pulse widths 500..2500 µs, speed in µs per second, time in ms
(at most 65535). ``VER`` answers the firmware version, ``Q`` answers ``.`` (move done) or
``+`` (moving), ``QP <ch>`` answers one byte: the pulse width / 10.
"""

from __future__ import annotations

from collections.abc import Mapping

CHANNELS = 32
MIN_US, MAX_US = 500, 2500
MAX_TIME_MS = 65535
CR = b"\r"


def group_move(
    pose: Mapping[int, int], speeds: Mapping[int, int] | None = None, time_ms: int | None = None
) -> bytes:
    """One line moving every channel of ``pose`` (µs) together; ``speeds`` in µs/s by channel
    (0 or missing: unlimited), ``time_ms`` for the whole move."""
    parts = []
    for ch in sorted(pose):
        us = pose[ch]
        if not 0 <= ch < CHANNELS:
            raise ValueError(f"channel {ch} is not in 0..{CHANNELS - 1}")
        if not MIN_US <= us <= MAX_US:
            raise ValueError(f"pulse width {us} us is not in {MIN_US}..{MAX_US}")
        speed = (speeds or {}).get(ch, 0)
        parts.append(f"#{ch}P{us}" + (f"S{speed}" if speed > 0 else ""))
    if not parts:
        raise ValueError("a move needs at least one channel")
    if time_ms is not None:
        if not 1 <= time_ms <= MAX_TIME_MS:
            raise ValueError(f"move time {time_ms} ms is not in 1..{MAX_TIME_MS}")
        parts.append(f"T{time_ms}")
    return "".join(parts).encode("ascii") + CR


def version() -> bytes:
    """VER: answered by the firmware version and a carriage return."""
    return b"VER" + CR


def query_moving() -> bytes:
    """Q: answered by ``.`` (done) or ``+`` (moving)."""
    return b"Q" + CR


def query_pulse(channel: int) -> bytes:
    """QP <ch>: answered by one byte, the pulse width in units of 10 µs."""
    if not 0 <= channel < CHANNELS:
        raise ValueError(f"channel {channel} is not in 0..{CHANNELS - 1}")
    return f"QP {channel}".encode("ascii") + CR
