"""Who answers on a serial port: the questions doctor asks, and what their answers mean (pure).

Three read-only questions, in an order that keeps each harmless to the boards it is not for:

1. Pololu Maestro: Get Errors (``0xA1``); a Maestro answers two bytes (reading clears its
   error register, nothing moves). Our firmware drops a byte that starts no frame; an SSC-32
   keeps it in its line buffer until the next carriage return, and ignores that line.
2. facesynth firmware: PING; it answers VERSION (protocol, firmware version, channels, output).
   A Maestro has already been told apart: its protocol would count these bytes as an error.
3. SSC-32: a carriage return (ending the line the bytes before made, which it ignores), then
   ``VER``; it answers its version and a carriage return.

None of them sets a target, a limit or a watchdog: nothing moves.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass

from facesynth.services.control.drivers.arduino import protocol as fw
from facesynth.services.control.drivers.arduino import replies
from facesynth.services.control.drivers.maestro import protocol as mp
from facesynth.services.control.drivers.ssc32 import protocol as sp

#: The sequence number of doctor's PING (a reply must echo it).
PING_SEQ = 0xD0C7


@dataclass(frozen=True)
class Answer:
    """The board that answered: its kind (``firmware``, ``maestro``, ``ssc32``), a description,
    and for our firmware its version and protocol."""

    kind: str
    description: str
    version: tuple[int, int, int] | None = None
    protocol: int | None = None


@dataclass(frozen=True)
class Question:
    """One read-only question: the bytes, how long to wait, how to read the answer (None while
    incomplete or not this board's), and how often to ask again while waiting (a board that
    is still booting misses the first)."""

    kind: str
    request: bytes
    wait_s: float
    read: Callable[[bytes], Answer | None]
    repeat_s: float | None = None


def read_maestro(data: bytes) -> Answer | None:
    """A Maestro's Get Errors answer: exactly two bytes, only known error bits set."""
    if len(data) != 2:
        return None
    bits = mp.u16(data)
    if bits >> len(mp.ERROR_BITS):
        return None  # not an error register: someone else's bytes
    errors = ", ".join(mp.error_names(bits)) or "none"
    return Answer("maestro", f"Pololu Maestro (errors: {errors})")


def read_firmware(data: bytes) -> Answer | None:
    """Our firmware's VERSION answer to doctor's PING (any bytes around it ignored)."""
    decoder = fw.FrameDecoder()
    for frame in decoder.feed(data):
        try:
            reply = replies.parse_reply(frame)
        except fw.ProtocolError:
            continue
        if isinstance(reply, replies.Version) and reply.seq == PING_SEQ:
            version = (reply.major, reply.minor, reply.patch)
            return Answer(
                "firmware",
                f"facesynth firmware {'.'.join(map(str, version))} (protocol {reply.protocol}, "
                f"{reply.channels} channels, {reply.output.name.lower()} output)",
                version=version,
                protocol=reply.protocol,
            )
    return None


_PRINTABLE = re.compile(r"[\x20-\x7e]{1,64}")


def read_ssc32(data: bytes) -> Answer | None:
    """An SSC-32's VER answer: one printable line ended by a carriage return."""
    if not data.endswith(b"\r"):
        return None
    text = data.rstrip(b"\r\n").lstrip(b"\r\n").decode("ascii", "replace")
    if not _PRINTABLE.fullmatch(text) or "SSC" not in text.upper():
        return None
    return Answer("ssc32", f"Lynxmotion SSC-32 ({text})")


def questions(boot_wait_s: float, detect_baud: bool = False) -> tuple[Question, ...]:
    """The three questions in their order; ``boot_wait_s`` is how long our firmware may take
    to answer (an Uno resets when its port opens and boots in about 2 s); ``detect_baud``
    sends a Maestro's baud-rate byte (``0xAA``) first, as its driver does in that mode."""
    baud_byte = bytes((mp.BAUD_INDICATION,)) if detect_baud else b""
    return (
        Question("maestro", baud_byte + mp.get_errors(), 0.3, read_maestro),
        Question("firmware", fw.ping(PING_SEQ), boot_wait_s, read_firmware, repeat_s=0.25),
        Question("ssc32", b"\r" + sp.version(), 0.4, read_ssc32),
    )


#: What each board's driver is called (the graph names drivers, the answers name boards).
DRIVER_OF = {"firmware": "arduino", "maestro": "maestro", "ssc32": "ssc32"}
