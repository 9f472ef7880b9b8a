"""facesynth.app.doctor.boards: the read-only questions and what their answers mean, with
malformed and foreign answers (never mistaken for a board)."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from facesynth.app.doctor import boards
from facesynth.app.simhead.maestro import Maestro
from facesynth.services.control.drivers.arduino import protocol as fw


def version_frame(seq: int = boards.PING_SEQ, protocol: int = 1) -> bytes:
    payload = bytes((protocol, 0, 1, 0, 16, 1, fw.MAX_PAYLOAD))
    return fw.encode_frame(seq, 0x82, payload)


def test_a_maestro_answer_is_two_bytes_of_known_errors() -> None:
    assert boards.read_maestro(b"\x00\x00") == boards.Answer(
        "maestro", "Pololu Maestro (errors: none)"
    )
    answer = boards.read_maestro(b"\x10\x00")
    assert answer is not None and "serial protocol error" in answer.description
    assert boards.read_maestro(b"\x00") is None  # still coming
    assert boards.read_maestro(b"\x00\x00\x00") is None  # not a Maestro's answer
    assert boards.read_maestro(b"\xff\xff") is None  # bits no Maestro has


def test_our_firmware_answers_its_version_to_doctors_ping() -> None:
    answer = boards.read_firmware(b"\x00junk" + version_frame())
    assert answer is not None
    assert answer.kind == "firmware" and answer.version == (0, 1, 0) and answer.protocol == 1
    assert "16 channels" in answer.description
    assert boards.read_firmware(version_frame(seq=7)) is None  # someone else's PING
    assert boards.read_firmware(version_frame()[:-1]) is None  # truncated
    corrupt = bytearray(version_frame())
    corrupt[6] ^= 0xFF
    assert boards.read_firmware(bytes(corrupt)) is None  # bad CRC


def test_an_ssc32_answers_its_version_line() -> None:
    assert boards.read_ssc32(b"SSC32-V2.50USB\r") == boards.Answer(
        "ssc32", "Lynxmotion SSC-32 (SSC32-V2.50USB)"
    )
    assert boards.read_ssc32(b"SSC32-V2.50USB") is None  # the line is not over
    assert boards.read_ssc32(b"hello\r") is None  # a line, not an SSC-32's
    assert boards.read_ssc32(b"SSC\x00\xff\r") is None
    assert boards.read_ssc32(b"\r") is None


@given(st.binary(max_size=64))
def test_noise_is_never_a_board_unless_it_is_the_answer(data: bytes) -> None:
    for read in (boards.read_maestro, boards.read_firmware, boards.read_ssc32):
        answer = read(data)  # never raises
        assert answer is None or answer.kind in boards.DRIVER_OF


@pytest.mark.parametrize("boot_wait", [0.5, 2.2])
def test_the_questions_come_in_the_safe_order(boot_wait: float) -> None:
    kinds = [q.kind for q in boards.questions(boot_wait)]
    assert kinds == ["maestro", "firmware", "ssc32"]
    assert boards.questions(boot_wait)[1].wait_s == boot_wait


def test_a_maestro_asked_first_only_reports_its_errors() -> None:
    """The first question, to the simulated head's Maestro: an answer, no target, no error."""
    maestro = Maestro()
    reply = maestro.feed(boards.questions(0.5)[0].request)
    assert boards.read_maestro(reply) == boards.Answer("maestro", "Pololu Maestro (errors: none)")
    assert maestro.errors == 0 and maestro.error_events == 0
    assert maestro.commands == [(0xA1,)]  # Get Errors, nothing else


def test_a_maestro_detecting_its_baud_rate_gets_the_baud_byte_first() -> None:
    (question, *_) = boards.questions(0.5, detect_baud=True)
    assert question.request == b"\xaa\xa1"
    maestro = Maestro()
    assert boards.read_maestro(maestro.feed(question.request)) is not None
    assert maestro.errors == 0 and maestro.error_events == 0
