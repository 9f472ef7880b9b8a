"""The TCP addresses the graph serves on (the live face page of a ``virtual`` control node,
``--foxglove``): each must be free on this host, or the node stops at start."""

from __future__ import annotations

import errno
import socket
from collections.abc import Sequence

from facesynth.app.doctor.report import Finding
from facesynth.services.control.drivers.virtual import AddressError, parse_address

FAMILY = "address"


def bind_problem(host: str, port: int) -> str | None:
    """None when a server could listen on ``host:port`` now (as aiohttp does, reusing the
    address), else why not."""
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except (socket.gaierror, UnicodeError) as exc:
        return f"cannot resolve {host!r}: {exc}"
    family, kind, proto, _, address = infos[0]
    with socket.socket(family, kind, proto) as sock:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            sock.bind(address)
        except OSError as exc:
            if exc.errno == errno.EADDRINUSE:
                return "taken: another program listens there"
            return f"cannot listen there: {exc.strerror or exc}"
    return None


def address_findings(addresses: Sequence[tuple[str, str, str]]) -> list[Finding]:
    """One line per ``(who, address, flag)`` the graph serves on."""
    findings = []
    for who, text, flag in addresses:
        subject = f"{text} ({who})"
        try:
            host, port = parse_address(text)
        except AddressError:
            host, port = "", -1
        problem = "expected HOST:PORT" if port < 0 else bind_problem(host, port)
        if problem is None:
            free = "any free port" if port == 0 else "free"
            findings.append(Finding(FAMILY, subject, free))
            continue
        findings.append(
            Finding(
                FAMILY,
                subject,
                problem,
                good=False,
                needed=True,
                fix=f"choose another with {flag} HOST:PORT (port 0 picks a free one)",
            )
        )
    return findings
