"""Ending a soak early: SIGINT (Ctrl-C) or SIGTERM, whatever the soak inherited for them.

A soak started in the background by a script (``nohup python -m tools.soak ... &``) inherits
SIGINT *ignored*, and Python then leaves it ignored (it turns SIGINT into
:exc:`KeyboardInterrupt` only when it was at its default): Ctrl-C and ``kill -INT`` did
nothing, and SIGTERM killed the soak on the spot, its children left running and no report.
:class:`EndSignals` handles both signals itself: the first raises :exc:`Interrupted` in the
main thread (where the soak's loop runs, so the sleep or wait under way ends at once); any
later one, or one during the clean-up after :meth:`EndSignals.disarm`, is only noted, so
undoing the fault under way, stopping the processes and writing the report are not cut short.
"""

from __future__ import annotations

import signal
from types import FrameType
from typing import Any

#: The signals that end a soak early.
ENDING = (signal.SIGINT, signal.SIGTERM)


class Interrupted(BaseException):
    """The soak was asked to end early (a :exc:`BaseException`, as :exc:`KeyboardInterrupt`
    is, so no ``except Exception`` on the way swallows it); ``signal`` names the signal."""

    def __init__(self, signal_name: str) -> None:
        super().__init__(signal_name)
        self.signal = signal_name

    @property
    def exit_code(self) -> int:
        """The shell's code for a run ended by this signal (130 for SIGINT, 143 for SIGTERM)."""
        return 128 + int(signal.Signals[self.signal])


class EndSignals:
    """SIGINT and SIGTERM handlers for the soak's main thread (:meth:`install`,
    :meth:`restore`)."""

    def __init__(self) -> None:
        self.armed = False
        self._previous: dict[signal.Signals, Any] = {}

    def install(self) -> None:
        """Handle :data:`ENDING` from now on: the first raises :exc:`Interrupted`."""
        for number in ENDING:
            self._previous[number] = signal.signal(number, self._handle)
        self.armed = True

    def disarm(self) -> None:
        """From now on a signal is only noted (the clean-up runs to its end)."""
        self.armed = False

    def restore(self) -> None:
        """The handlers there were before :meth:`install`."""
        self.armed = False
        for number, previous in self._previous.items():
            signal.signal(number, previous)
        self._previous.clear()

    def _handle(self, number: int, frame: FrameType | None) -> None:
        name = signal.Signals(number).name
        if self.armed:
            self.armed = False
            print(f"soak: {name}: ending early; undoing the fault under way, stopping, reporting",
                  flush=True)  # fmt: skip
            raise Interrupted(name)
        print(f"soak: {name}: already stopping", flush=True)
