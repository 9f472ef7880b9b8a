"""Serial ports and the board that answers on each (:mod:`.boards`'s questions, asked here).

The ports looked at: those pyserial lists (USB serial adapters and boards, real UARTs), the
graph's boards' ports, and any given with ``--serial``. Each is opened locked, as the drivers
open it: a port a running service holds is reported as in use and never written to. Ports
are asked in parallel; a silent one costs about a second (about three on a USB port, where an
Uno may be booting).
"""

from __future__ import annotations

import functools
import os
import time
from collections.abc import Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import serial
import serial.tools.list_ports

from facesynth.app.doctor.boards import DRIVER_OF, Answer, Question, questions
from facesynth.app.doctor.needs import SERIAL_DRIVERS, SerialNeed
from facesynth.app.doctor.report import Finding

FAMILY = "serial"
#: The baud rate of ports the graph does not name (every driver's default).
DEFAULT_BAUD = 115200


@dataclass(frozen=True)
class PortResult:
    """What one port said: the board that answered, or why none could."""

    port: str
    answer: Answer | None = None
    problem: str | None = None
    #: Not asked: a built-in UART nobody named (a serial console may listen there).
    unasked: bool = False


def listed_ports() -> list[tuple[str, bool]]:
    """The serial ports pyserial finds on this host, and whether each is a USB device (a
    board or adapter; the others are built-in UARTs, where a serial console may listen)."""
    ports = serial.tools.list_ports.comports()
    return sorted((info.device, info.vid is not None) for info in ports)


def boot_wait(port: str) -> float:
    """How long our firmware may take to answer on ``port``: an Arduino's USB port resets the
    board when opened (2 s of bootloader), a pty or a network port does not."""
    return 2.2 if "ttyACM" in port or "ttyUSB" in port else 0.5


def _reason(exc: Exception) -> str:
    text = str(exc)
    if "exclusively lock" in text or "Resource temporarily unavailable" in text:
        return "in use by another program (it holds the port's lock); not probed"
    errno = getattr(exc, "errno", None)
    if isinstance(errno, int) and errno > 0:
        return f"cannot open it: {os.strerror(errno)}"
    return f"cannot open it: {text or type(exc).__name__}"


def ask(link: serial.SerialBase, question: Question) -> Answer | None:
    """Ask one question on an open port; the answer, or None when none came in time."""
    link.reset_input_buffer()
    data = bytearray()
    start = time.monotonic()
    deadline = start + question.wait_s
    sent_at = -1.0
    while True:
        now = time.monotonic()
        if sent_at < 0 or (question.repeat_s and now - sent_at >= question.repeat_s):
            link.write(question.request)
            link.flush()
            sent_at = now
        chunk = link.read(link.in_waiting or 1)
        if chunk:
            data += chunk
            answer = question.read(bytes(data))
            if answer is not None:
                return answer
        if now >= deadline:
            return None


def probe_port(port: str, baud: int = DEFAULT_BAUD, detect_baud: bool = False) -> PortResult:
    """Open ``port`` (a device path, ``socket://`` or ``rfc2217://``) and ask who is there
    (``detect_baud``: a Maestro's baud-rate byte first)."""
    kwargs: dict[str, object] = {"baudrate": baud, "timeout": 0.05, "write_timeout": 0.5}
    if "://" not in port:
        kwargs["exclusive"] = True
    try:
        link = serial.serial_for_url(port, **kwargs)
    except (serial.SerialException, OSError, ValueError) as exc:
        return PortResult(port, problem=_reason(exc))
    try:
        for question in questions(boot_wait(port), detect_baud):
            answer = ask(link, question)
            if answer is not None:
                return PortResult(port, answer=answer)
        return PortResult(port)
    except (serial.SerialException, OSError) as exc:
        return PortResult(port, problem=f"failed while asking: {exc}")
    finally:
        link.close()


def probe_ports(ports: Sequence[tuple[str, int, bool]]) -> list[PortResult]:
    """Probe each ``(port, baud, detect_baud)`` at once (in threads), in the same order."""
    if not ports:
        return []
    with ThreadPoolExecutor(max_workers=min(8, len(ports))) as pool:
        return list(pool.map(lambda item: probe_port(*item), ports))


def ports_to_probe(
    needed: Iterable[SerialNeed], extra: Iterable[str], listed: Iterable[tuple[str, bool]]
) -> tuple[list[tuple[str, int, bool]], list[str]]:
    """The ports to ask: the graph's (at their baud rates), the ``--serial`` ones, the listed
    USB ones; and the listed built-in UARTs nobody named, left alone (a login prompt on a
    serial console must not be typed at)."""
    ports: dict[str, tuple[int, bool]] = {}
    for need in needed:
        if need.port:
            ports.setdefault(need.port, (need.baud or DEFAULT_BAUD, need.detect_baud))
    for port in extra:
        ports.setdefault(port, (DEFAULT_BAUD, False))
    unasked = []
    for port, usb in listed:
        if usb:
            ports.setdefault(port, (DEFAULT_BAUD, False))
        elif port not in ports:
            unasked.append(port)
    return [(port, baud, detect) for port, (baud, detect) in ports.items()], unasked


def serial_findings(results: Sequence[PortResult], needed: Sequence[SerialNeed]) -> list[Finding]:
    """One line per port (and per board node without a port), judged by what the graph drives
    there (pure)."""
    by_port = {need.port: need for need in needed if need.port}
    findings = [
        Finding(
            FAMILY,
            f"control node {need.node}",
            f"the {need.driver} driver has no port",
            good=False,
            needed=True,
            fix=f"give it --port (e.g. /dev/ttyACM0){_listed_hint(results)}",
        )
        for need in needed
        if not need.port
    ]
    if not results and not needed:
        findings.append(Finding(FAMILY, "ports", "no serial port found", good=None))
    for result in results:
        need = by_port.get(result.port)
        findings.append(_port_finding(result, need))
    return findings


def _listed_hint(results: Sequence[PortResult]) -> str:
    answering = [r.port for r in results if r.answer is not None]
    return f"; boards answer on {', '.join(answering)}" if answering else ""


def _port_finding(result: PortResult, need: SerialNeed | None) -> Finding:
    subject = result.port
    if need is not None:
        subject += f" (control node {need.node}, {need.driver})"
    found = functools.partial(Finding, FAMILY, subject)
    if result.unasked:
        return found(
            "a built-in serial port, not asked (a serial console may listen there): "
            f"facesynth doctor --serial {result.port} asks it",
            good=None,
        )
    if result.problem is not None:
        return found(
            result.problem,
            good=None if need is None else False,
            needed=need is not None,
            fix="close the program that holds it, or check the cable and permissions "
            "(the dialout group)",
        )
    answer = result.answer
    if answer is None:
        text = "no answer (not our firmware, a Maestro or an SSC-32, or another baud rate)"
        if need is None:
            return found(text, good=None)
        return found(
            text,
            good=False,
            needed=True,
            fix=f"check the board is powered and connected, and --baud (tried {need.baud})",
        )
    if need is None:
        return found(f"{answer.description}: use --driver {DRIVER_OF[answer.kind]}")
    if SERIAL_DRIVERS[need.driver] != answer.kind:
        return found(
            f"{answer.description} answers, not what the {need.driver} driver drives",
            good=False,
            needed=True,
            fix=f"use --driver {DRIVER_OF[answer.kind]} for this port, or give the right --port",
        )
    return found(answer.description)
