"""Fuzz the host side of the serial protocols: the arduino driver's reply decoder (framed,
CRC-checked), and the in-order answers of the Maestro and the SSC-32 (ReplyQueue, then the
drivers' readings of them). The firmware's own parser is fuzzed in test_fuzz_firmware_parser.
"""

from __future__ import annotations

import asyncio
import itertools
import struct

import pytest
from fuzzing import FUZZ, TIMEOUT, check_tally, outcome, tally
from hypothesis import given
from hypothesis import strategies as st
from mutations import damaged

from facesynth.services.control.drivers.arduino import protocol as proto
from facesynth.services.control.drivers.arduino import replies
from facesynth.services.control.drivers.maestro import protocol as mp
from facesynth.services.control.drivers.replies import ReplyQueue

pytestmark = [pytest.mark.fuzz, TIMEOUT]

REPLY_CODES = [m for m in proto.MESSAGES if m.direction == "reply"]


# What a reply frame draws from, built once (not again inside every draw).
_SEQS = st.integers(0, 0xFFFF)
_REPLY_KINDS = st.sampled_from(["reply", "reply", "any", "damaged"])
_CODES = st.integers(0, 0xFF)
_PAYLOADS = st.binary(max_size=proto.MAX_PAYLOAD)
_REPLY_MESSAGES = st.sampled_from(REPLY_CODES)


@st.composite
def reply_frames(draw: st.DrawFn) -> bytes:
    """A reply frame: well formed with any values, any code and payload, or damaged."""
    seq = draw(_SEQS)
    kind = draw(_REPLY_KINDS)
    if kind == "any":
        code = draw(_CODES)
        return proto.encode_frame(seq, code, draw(_PAYLOADS))
    message = draw(_REPLY_MESSAGES)
    frame = proto.encode_frame(
        seq, message.code, draw(st.binary(min_size=message.size, max_size=message.size))
    )
    return draw(damaged(frame)) if kind == "damaged" else frame


def test_arduino_replies_decode_or_are_counted_malformed() -> None:
    target = "arduino ReplyDecoder (serial replies)"
    record = tally(target)

    @FUZZ
    @given(
        st.lists(st.one_of(reply_frames(), st.binary(max_size=24)), max_size=8),
        st.lists(st.integers(1, 64), min_size=1, max_size=12),
    )
    def case(parts: list[bytes], sizes: list[int]) -> None:
        stream = b"".join(parts)
        decoder = replies.ReplyDecoder()
        got: list[replies.Reply] = []
        i = 0
        for n in itertools.cycle(sizes):  # as the serial port delivers it: in chunks
            if i >= len(stream):
                break
            got += decoder.feed(stream[i : i + n])
            i += n
            assert decoder.frames.pending <= proto.MAX_REPLY_PAYLOAD + proto.FRAME_OVERHEAD
        for _ in range(proto.MAX_REPLY_PAYLOAD + proto.FRAME_OVERHEAD):  # the line goes quiet
            if not decoder.frames.pending:
                break
            got += decoder.discard_partial()
        assert decoder.frames.pending == 0
        for reply in got:
            assert isinstance(reply, replies.Ack | replies.Nack | replies.Version | replies.Status)
            assert 0 <= reply.seq <= 0xFFFF
        record.count("replies" if got else "none")

    case()
    check_tally(target, "replies", "none")


def test_arduino_parse_reply_types_a_frame_or_raises_protocol_error() -> None:
    target = "arduino parse_reply"

    # a reply's code with a payload of its size (random sizes rarely are), or any of either
    frames = st.one_of(
        st.sampled_from(REPLY_CODES).flatmap(
            lambda m: st.tuples(st.just(m.code), st.binary(min_size=m.size, max_size=m.size))
        ),
        st.tuples(
            st.one_of(st.sampled_from([m.code for m in REPLY_CODES]), st.integers(0, 255)),
            st.binary(max_size=60),
        ),
    )

    @FUZZ
    @given(st.integers(0, 0xFFFF), frames)
    def case(seq: int, frame: tuple[int, bytes]) -> None:
        code, payload = frame
        outcome(
            target,
            lambda: replies.parse_reply(proto.Frame(seq, code, payload)),
            proto.ProtocolError,
        )

    case()
    check_tally(target, "valid", "refused")


# --- Maestro and SSC-32: answers in order, without framing ----------------------------------------

LOOP = asyncio.new_event_loop()


#: Requests (a size, or a terminator) and the bytes the board sends back, in chunks.
conversations = st.tuples(
    st.lists(
        st.one_of(
            st.tuples(st.sampled_from([1, 2]), st.none()),
            st.tuples(st.none(), st.just(b"\r")),
        ),
        max_size=5,
    ),
    st.lists(st.one_of(st.binary(max_size=6), st.binary(max_size=300)), max_size=6),
)


def test_maestro_and_ssc32_answers_are_matched_in_order_and_read() -> None:
    target = "ReplyQueue + Maestro/SSC-32 answers"
    record = tally(target)

    async def converse(
        requests: list[tuple[int | None, bytes | None]], chunks: list[bytes]
    ) -> None:
        queue = ReplyQueue(limit=64)
        futures = [(size, until, queue.expect(size=size, until=until)) for size, until in requests]
        for chunk in chunks:
            queue.feed(chunk)
        answered = 0
        for size, until, future in futures:
            if not future.done():
                continue
            if future.exception() is not None:
                assert isinstance(future.exception(), ValueError)
                continue
            answer = future.result()
            answered += 1
            if size is not None:
                assert len(answer) == size
                if size == 2:  # Maestro Get Errors / Get Position
                    assert isinstance(mp.error_names(mp.u16(answer)), list)
                else:  # SSC-32 pulse query (10 µs units) or "+"/"." moving query
                    assert 0 <= answer[0] * 10 <= 2550
            else:
                assert until is not None and answer.endswith(until) and len(answer) <= 64 + 1
                assert isinstance(answer.strip().decode("ascii", "replace"), str)  # version
        queue.reset()
        record.count("answered" if answered else "unanswered")

    @FUZZ
    @given(conversations)
    def case(conversation: tuple[list[tuple[int | None, bytes | None]], list[bytes]]) -> None:
        LOOP.run_until_complete(converse(*conversation))

    case()
    check_tally(target, "answered", "unanswered")


def test_maestro_u16_reads_two_bytes_or_raises_value_error() -> None:
    target = "maestro u16 + error_names"

    @FUZZ
    @given(st.binary(max_size=4))
    def case(answer: bytes) -> None:
        bits = outcome(target, lambda: mp.u16(answer), ValueError)
        if bits is not None:
            assert bits == struct.unpack("<H", answer)[0]
            assert all(isinstance(name, str) for name in mp.error_names(bits))

    case()
    check_tally(target, "valid", "refused")


def test_doctors_board_answers_are_a_board_or_none() -> None:
    """``facesynth doctor``'s readings of whatever a port sends back to its three questions:
    a board only for its own answer, never an exception (facesynth.app.doctor.boards)."""
    from facesynth.app.doctor import boards

    target = "doctor board answers (maestro, firmware, ssc32)"
    record = tally(target)
    version = proto.encode_frame(boards.PING_SEQ, 0x82, bytes((1, 0, 1, 0, 16, 1, 144)))
    answers = st.one_of(
        st.binary(max_size=40),
        st.binary(min_size=2, max_size=2),
        st.just(version),
        damaged(version),
        st.builds(
            lambda text: text.encode("ascii") + b"\r", st.text("SC32-V.0123456789U\r", max_size=20)
        ),
        reply_frames(),
    )

    @FUZZ
    @given(st.lists(answers, max_size=3))
    def case(parts: list[bytes]) -> None:
        data = b"".join(parts)
        found = []
        for read in (boards.read_maestro, boards.read_firmware, boards.read_ssc32):
            answer = read(data)
            if answer is not None:
                assert answer.kind in boards.DRIVER_OF and "\n" not in answer.description
                found.append(answer.kind)
        record.count("board" if found else "none")

    case()
    check_tally(target, "board", "none")
