"""What the read-backs of a smart servo bus say of each servo (the bus thread's bookkeeping).

Each servo has its latest status, a fault (a hardware error it reports, or
:data:`NOT_ANSWERING` after :data:`MISSES` missed read-backs in a row) and the time it last
answered. A servo that does not answer is asked again at most every :data:`REPROBE_S`; a bus
where no servo has answered for :data:`SILENT_S` counts as lost. Not thread-safe: the caller
holds its own lock.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from facesynth.services.control.drivers.bus_servo.bus import Status

SILENT_S = 2.0
REPROBE_S = 1.0
#: Read-backs in a row a servo must miss to show as "not answering" (one lost answer is not).
MISSES = 3
NOT_ANSWERING = "not answering"


class ServoHealth:
    """Statuses, faults and answer times of a bus's servos, by id."""

    def __init__(self) -> None:
        self.statuses: dict[int, Status] = {}
        self.faults: dict[int, str] = {}
        self._last_answer: dict[int, float] = {}
        self._last_probe: dict[int, float] = {}
        self._misses: dict[int, int] = {}

    def connected(self, faults: Mapping[int, str], ids: Iterable[int], now: float) -> None:
        """A new connection: the faults its pings reported; every servo answered ``now``."""
        self.faults = dict(faults)
        self._last_answer = dict.fromkeys(ids, now)
        self._misses = {}

    def pick(self, ids: list[int], turn: int, size: int, now: float) -> list[int]:
        """Up to ``size`` servos to read next, round robin from ``turn`` (a servo not answering
        is asked again once a second)."""
        picked: list[int] = []
        for k in range(len(ids)):
            servo_id = ids[(turn + k) % len(ids)]
            if len(picked) >= size:
                break
            silent = self.faults.get(servo_id) == NOT_ANSWERING
            if silent and now - self._last_probe.get(servo_id, 0.0) < REPROBE_S:
                continue  # asked again once a second
            picked.append(servo_id)
        return picked

    def update(
        self, statuses: Mapping[int, Status | None], now: float
    ) -> list[tuple[int, str, str]]:
        """Take one read-back (None: no answer); returns each change as (id, fault before,
        fault now), ``""`` for none."""
        said: list[tuple[int, str, str]] = []
        for servo_id, status in statuses.items():
            before = self.faults.get(servo_id, "")
            if status is None:
                misses = self._misses[servo_id] = self._misses.get(servo_id, 0) + 1
                self._last_probe[servo_id] = now
                fault = before or (NOT_ANSWERING if misses >= MISSES else "")
            else:
                self._misses[servo_id] = 0
                self.statuses[servo_id] = status
                self._last_answer[servo_id] = now
                fault = status.fault
            if fault:
                self.faults[servo_id] = fault
            else:
                self.faults.pop(servo_id, None)
            if fault != before:
                said.append((servo_id, before, fault))
        return said

    def silent(self, now: float) -> bool:
        """Whether no servo has answered for :data:`SILENT_S`."""
        return bool(self._last_answer) and max(self._last_answer.values()) < now - SILENT_S
