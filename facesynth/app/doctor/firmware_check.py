"""The firmware on each connected board against the firmware bundled with this facesynth (pure).

Our firmware answers PING with its protocol and version (:mod:`.boards`); the bundled version is
the one in ``firmware/`` (:func:`facesynth.app.firmware.bundled_version`). A protocol this
facesynth does not speak keeps the arduino driver from using the board (flash it); another
version of the same protocol works, and is said so.
"""

from __future__ import annotations

from collections.abc import Sequence

from facesynth.app.doctor.needs import SerialNeed
from facesynth.app.doctor.report import Finding
from facesynth.app.doctor.serial_ports import PortResult
from facesynth.services.control.drivers.arduino.protocol import PROTOCOL_VERSION

FAMILY = "firmware"


def version_text(version: tuple[int, int, int] | None) -> str:
    """``0.1.0``, or ``unknown`` without the firmware sources."""
    return ".".join(map(str, version)) if version is not None else "unknown"


def firmware_findings(
    results: Sequence[PortResult],
    needed: Sequence[SerialNeed],
    bundled: tuple[int, int, int] | None,
) -> list[Finding]:
    """One line per board running our firmware: its version against the bundled one."""
    used = {need.port for need in needed if need.driver == "arduino"}
    findings = []
    for result in results:
        answer = result.answer
        if answer is None or answer.kind != "firmware" or answer.version is None:
            continue
        flash = f"facesynth firmware flash --port {result.port}"
        board = version_text(answer.version)
        if answer.protocol != PROTOCOL_VERSION:
            findings.append(
                Finding(
                    FAMILY,
                    result.port,
                    f"firmware {board} speaks protocol {answer.protocol}, this facesynth "
                    f"speaks {PROTOCOL_VERSION}",
                    good=False,
                    needed=result.port in used,
                    fix=f"flash the bundled firmware ({version_text(bundled)}): {flash}",
                )
            )
        elif bundled is not None and answer.version != bundled:
            findings.append(
                Finding(
                    FAMILY,
                    result.port,
                    f"firmware {board} on the board, {version_text(bundled)} bundled (same "
                    f"protocol {PROTOCOL_VERSION}: it works); to update: {flash}",
                    good=None,
                )
            )
        else:
            findings.append(
                Finding(
                    FAMILY, result.port, f"firmware {board}, as bundled ({version_text(bundled)})"
                )
            )
    return findings
