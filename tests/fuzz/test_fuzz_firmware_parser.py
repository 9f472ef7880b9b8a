"""Fuzz the servo firmware's real command parser and device logic (firmware/facesynth_servo,
compiled for this host with AddressSanitizer and UBSan: firmware/tests/fuzz_device.c).

One harness process serves every case: the device is booted, fed the case's bytes and ticks,
and checks after every byte and every millisecond that no channel's limits are invalid, no
position or target is outside its limits, and no rate-limited channel steps faster than its
``max_step``; it answers with the device's state and the reply frames it sent, which the host
driver's reply decoder must read without a single malformed frame. (tests/firmware covers the
protocol's codecs and the emulated Uno; this is the firmware's C code under hostile input.)
"""

from __future__ import annotations

import shutil
import struct
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest
from fuzzing import FUZZ, TIMEOUT, check_tally, tally
from hypothesis import given
from hypothesis import strategies as st
from mutations import damaged

from facesynth.services.control.drivers.arduino import protocol as proto
from facesynth.services.control.drivers.arduino import replies

pytestmark = [pytest.mark.fuzz, TIMEOUT]

FIRMWARE = Path(__file__).resolve().parents[2] / "firmware"
HARNESS = FIRMWARE / "build" / "host" / "fuzz_device"
ABS_MIN, ABS_MAX = 500, 2500


class Harness:
    """The fuzz harness process: one case in, the device's state out."""

    def __init__(self) -> None:
        self.process = subprocess.Popen(
            [str(HARNESS)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE
        )

    def run(self, channels: int, ops: list[tuple[str, bytes | int]]) -> bytes:
        body = bytearray([channels])
        for kind, value in ops:
            if kind == "b":
                assert isinstance(value, bytes)
                body += b"b" + struct.pack("<H", len(value)) + value
            else:
                body += b"t" + struct.pack("<H", value)
        assert self.process.stdin is not None and self.process.stdout is not None
        self.process.stdin.write(struct.pack("<I", len(body)) + body)
        self.process.stdin.flush()
        head = self.process.stdout.read(4)
        if len(head) < 4:
            self.process.wait(timeout=10)
            assert self.process.stderr is not None
            raise AssertionError(
                f"the firmware harness died (exit {self.process.returncode}): "
                + self.process.stderr.read().decode(errors="replace")[-3000:]
            )
        (size,) = struct.unpack("<I", head)
        return self.process.stdout.read(size)

    def close(self) -> None:
        assert self.process.stdin is not None
        self.process.stdin.close()
        assert self.process.wait(timeout=10) == 0


@pytest.fixture(scope="module")
def harness() -> Iterator[Harness]:
    if shutil.which("gcc") is None:
        pytest.fail("the firmware fuzz harness needs gcc (Debian: gcc libc6-dev)")
    subprocess.run(["make", "-s", "-C", str(FIRMWARE), "fuzz-harness"], check=True)
    running = Harness()
    yield running
    running.close()


# --- cases ---------------------------------------------------------------------------------------

u16 = st.integers(0, 0xFFFF)
plausible_us = st.one_of(st.integers(0, 3000), u16)
# Every strategy a case draws from, built once (not again inside every draw).
_KINDS = st.sampled_from(["all", "some", "limits", "watchdog", "neutral", "query", "any"])
_ALL = {count: st.lists(plausible_us, min_size=count, max_size=count) for count in range(1, 17)}
_SOME = st.lists(st.tuples(st.integers(0, 20), plausible_us), min_size=1, max_size=6)
_LIMITS = st.lists(
    st.tuples(
        st.integers(0, 20), plausible_us, plausible_us, plausible_us,
        st.one_of(st.integers(0, 50), u16),
    ),
    min_size=1,
    max_size=4,
)  # fmt: skip
_QUERIES = st.sampled_from([0x01, 0x02])
_PAYLOADS = st.binary(max_size=proto.MAX_PAYLOAD)
_CODES = st.integers(0, 0xFF)
_CHANNELS = st.one_of(st.just(16), st.integers(1, 16), st.integers(0, 255))
_OP_COUNTS = st.integers(1, 6)
_OPS = st.sampled_from(["frame", "frame", "frame", "damaged", "noise", "tick"])
_NOISE = st.binary(max_size=80)
_TICKS = st.one_of(st.integers(0, 60), st.integers(0, 1200))


@st.composite
def commands(draw: st.DrawFn, channels: int) -> bytes:
    """One frame: a well-formed command with hostile values, or any code and payload."""
    seq = draw(u16)
    count = max(1, min(channels, 16))
    kind = draw(_KINDS)
    if kind == "all":
        values = draw(_ALL[count])
        return proto.encode_frame(seq, 0x10, struct.pack(f"<{count}H", *values))
    if kind == "some":
        entries = draw(_SOME)
        return proto.encode_frame(seq, 0x11, b"".join(struct.pack("<BH", *e) for e in entries))
    if kind == "limits":
        entries = draw(_LIMITS)
        return proto.encode_frame(seq, 0x20, b"".join(struct.pack("<BHHHH", *e) for e in entries))
    if kind == "watchdog":
        return proto.encode_frame(seq, 0x21, struct.pack("<H", draw(u16)))
    if kind == "neutral":
        return proto.encode_frame(seq, 0x12)
    if kind == "query":
        return proto.encode_frame(seq, draw(_QUERIES))
    payload = draw(_PAYLOADS)
    return proto.encode_frame(seq, draw(_CODES), payload)


@st.composite
def cases(draw: st.DrawFn) -> tuple[int, list[tuple[str, bytes | int]]]:
    channels = draw(_CHANNELS)
    ops: list[tuple[str, bytes | int]] = []
    for _ in range(draw(_OP_COUNTS)):
        kind = draw(_OPS)
        if kind == "frame":
            ops.append(("b", draw(commands(channels))))
        elif kind == "damaged":
            ops.append(("b", draw(damaged(draw(commands(channels))))))
        elif kind == "noise":
            ops.append(("b", draw(_NOISE)))
        else:
            ops.append(("t", draw(_TICKS)))
    return channels, ops


# --- the property --------------------------------------------------------------------------------


def test_the_firmware_never_breaks_its_limits_and_always_answers_in_frames(
    harness: Harness,
) -> None:
    target = "firmware device.c (ASan+UBSan)"
    record = tally(target)

    @FUZZ
    @given(cases())
    def case(scenario: tuple[int, list[tuple[str, bytes | int]]]) -> None:
        channels, ops = scenario
        answer = harness.run(channels, ops)
        breaches, count = struct.unpack_from("<IB", answer)
        assert breaches == 0, f"{breaches} safety breaches in the firmware"
        assert count == min(channels, 16)
        at = 5
        for _ in range(count):
            low, neutral, high, _step, goal, current = struct.unpack_from("<6H", answer, at)
            at += 12
            assert ABS_MIN <= low <= neutral <= high <= ABS_MAX
            assert low <= goal <= high and low <= current <= high
        counters = struct.unpack_from("<8I", answer, at)
        at += 32 + 16 + 1
        (size,) = struct.unpack_from("<I", answer, at)
        replies_bytes = answer[at + 4 : at + 4 + size]
        decoder = replies.ReplyDecoder()
        got = decoder.feed(replies_bytes)
        assert decoder.malformed == 0 and decoder.frames.dropped_bytes == 0
        assert all(
            isinstance(r, replies.Ack | replies.Nack | replies.Version | replies.Status)
            for r in got
        )
        record.count("applied" if counters[0] else "refused")

    case()
    check_tally(target, "applied", "refused")
