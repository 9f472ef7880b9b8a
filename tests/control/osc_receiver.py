"""A real OSC server (python-osc) on loopback that keeps every VMC message it receives.

One thread takes the datagrams in the order they arrive, as a VMC receiver does (Unity's uOSC
reads one socket in one loop). python-osc's threading server handles each datagram in a thread
of its own, so under load two bundles' messages interleaved and a pose read as a mix of two."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from pythonosc.dispatcher import Dispatcher
from pythonosc.osc_server import BlockingOSCUDPServer


class Receiver:
    """Messages as ``(address, args)``, bundles unpacked by python-osc, in arrival order."""

    def __init__(self) -> None:
        self.messages: list[tuple[str, tuple[Any, ...]]] = []
        self._lock = threading.Lock()
        self.port = 0

    def handle(self, address: str, *args: Any) -> None:
        with self._lock:
            self.messages.append((address, args))

    def wait_for(self, address: str, count: int, timeout: float = 5.0) -> list[tuple[Any, ...]]:
        """The args of the first ``count`` messages to ``address`` (fails after ``timeout``)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            found = self.of(address)
            if len(found) >= count:
                return found[:count]
            time.sleep(0.01)
        raise AssertionError(f"{len(self.of(address))} of {count} {address} messages arrived")

    def of(self, address: str) -> list[tuple[Any, ...]]:
        with self._lock:
            return [args for a, args in self.messages if a == address]

    def blendshapes(self, apply_index: int = -1) -> dict[str, float]:
        """The Blend/Val values in force at one Blend/Apply (the last by default)."""
        with self._lock:
            messages = list(self.messages)
        applies = [i for i, (a, _) in enumerate(messages) if a == "/VMC/Ext/Blend/Apply"]
        values: dict[str, float] = {}
        for address, args in messages[: applies[apply_index]]:
            if address == "/VMC/Ext/Blend/Val":
                values[args[0]] = args[1]
        return values


@contextmanager
def osc_receiver() -> Iterator[Receiver]:
    receiver = Receiver()
    dispatcher = Dispatcher()
    dispatcher.set_default_handler(receiver.handle)
    server = BlockingOSCUDPServer(("127.0.0.1", 0), dispatcher)
    receiver.port = server.server_address[1]
    thread = threading.Thread(target=server.serve_forever, name="osc-receiver", daemon=True)
    thread.start()
    try:
        yield receiver
    finally:
        server.shutdown()
        server.server_close()
        thread.join(5)
