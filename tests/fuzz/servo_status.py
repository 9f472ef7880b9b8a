"""What the Dynamixel and Feetech fuzz targets share: streams of status packets (good, damaged,
noise), the oracle of the status packets a stream really holds (by the emulators' own
parsers, written from the vendors' documents), and the check of a Sync Read over a stream."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from fuzzing import FUZZ, check_tally, tally
from hypothesis import given
from hypothesis import strategies as st
from mutations import damaged
from sdk_ports import MemoryPort

Split = Callable[[bytearray], list[tuple[int, bytes | None]]]


def status_streams(
    packet: Callable[[int, bytes], bytes],
    errors: Sequence[int],
    sizes: Sequence[int],
    noise: int,
) -> st.SearchStrategy[bytes]:
    """Up to five status packets of ids 1..6 (``packet(id, error byte + data)``), each good,
    damaged or replaced by noise of up to ``noise`` bytes."""
    # What a stream draws from, built once (not again inside every draw).
    counts, ids = st.integers(0, 5), st.integers(1, 6)
    error_bytes, data_sizes = st.sampled_from(errors), st.sampled_from(sizes)
    data = {size: st.binary(min_size=size, max_size=size) for size in set(sizes)}
    kinds = st.sampled_from(["good", "good", "damaged", "noise"])
    noises = st.binary(max_size=noise)

    @st.composite
    def streams(draw: st.DrawFn) -> bytes:
        parts = []
        for _ in range(draw(counts)):
            servo_id = draw(ids)
            error = draw(error_bytes)
            size = draw(data_sizes)
            made = packet(servo_id, bytes((error,)) + draw(data[size]))
            kind = draw(kinds)
            if kind == "damaged":
                made = draw(damaged(made))
            elif kind == "noise":
                made = draw(noises)
            parts.append(made)
        return b"".join(parts)

    return streams()


Found = set[tuple[int, int, bytes]]


def valid_status_packets(
    stream: bytes, header: bytes, split: Split, status: Callable[[bytes], bytes | None]
) -> Found:
    """(id, error byte, data) of every packet with a good CRC/checksum anywhere in ``stream``
    (whatever precedes it), by the emulator's ``split``; ``status(body)`` is the error byte
    and data of a status packet's body, or None for a body that is not one."""
    found = set()
    at = stream.find(header)
    while at >= 0:
        for servo_id, body in split(bytearray(stream[at:])):
            answer = status(body) if body is not None else None
            if answer:
                found.add((servo_id, answer[0], answer[1:]))
            break
        at = stream.find(header, at + 1)
    return found


def check_sync_read(
    target: str,
    streams: Any,
    make_bus: Callable[[], Any],
    valid: Callable[[bytes], Found],
    position: Callable[[bytes], int],
    size: int,
) -> None:
    """Fuzz ``make_bus().read(ids)`` over ``streams`` answered in chunks: every servo is in the
    result, and every status read back is one of the stream's valid packets for that id."""
    record = tally(target)
    ids = [1, 2, 3, 4, 5]

    @FUZZ
    @given(streams, st.integers(1, 64))
    def case(stream: bytes, chunk: int) -> None:
        bus = make_bus()
        bus.port = MemoryPort(stream, chunk)
        statuses = bus.read(ids)
        assert set(statuses) == set(ids)
        found = valid(stream)
        for servo_id, status in statuses.items():
            if status is None:
                continue
            assert any(
                i == servo_id and len(data) == size and position(data) == status.position
                for i, _, data in found
            ), (servo_id, status)
        record.count("read" if any(statuses.values()) else "none")

    case()
    check_tally(target, "read", "none")


def check_status_parser(
    target: str,
    take: Callable[[bytearray], tuple[list[tuple[int, int, bytes]], int]],
    streams: Any,
    valid: Callable[[bytes], Found],
) -> None:
    """Fuzz a status packet parser of :mod:`facesynth.services.control.drivers.bus_servo.wire` over
    streams fed in two parts: it never raises, keeps at most what it was given, and every
    packet it returns is a valid one of the stream (error byte and data as sent)."""
    record = tally(target)

    @FUZZ
    @given(streams, st.data())
    def case(stream: bytes, data: Any) -> None:
        cut = data.draw(st.integers(0, len(stream)))
        buffer = bytearray(stream[:cut])
        packets, damaged_count = take(buffer)
        buffer += stream[cut:]
        more, more_damaged = take(buffer)
        assert len(buffer) <= len(stream) and damaged_count + more_damaged >= 0
        found = valid(stream)
        for answer in packets + more:
            assert answer in found, answer
        record.count("packets" if packets or more else "none")

    case()
    check_tally(target, "packets", "none")
