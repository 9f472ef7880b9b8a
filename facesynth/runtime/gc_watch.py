"""Garbage-collector passes of a running service: how many, how long.

A service process calls ``gc.freeze()`` once its start-up objects are loaded
(:func:`facesynth.app.chain.freeze_startup_objects`), so the collector has little to scan
afterwards. :class:`GcWatch` counts the passes that still run and times them, so a benchmark
can tell whether the collector is behind a late frame: a service logs the figures when it stops
(``gc: …``), and ``facesynth bench chain`` reads them from each process's log.
"""

from __future__ import annotations

import gc
import re
import time
from dataclasses import dataclass, field
from typing import Any

#: How :meth:`GcWatch.summary` reads, for the benchmark to parse back.
SUMMARY = re.compile(r"gc: (\d+) passes \((\d+) of generation 2\), longest ([0-9.]+) ms")


@dataclass
class GcWatch:
    """Times every collector pass while installed (:meth:`start` … :meth:`stop`)."""

    passes: int = 0
    oldest: int = 0
    longest_ms: float = 0.0
    total_ms: float = 0.0
    _started: float | None = field(default=None, repr=False)

    def start(self) -> None:
        """Begin watching (idempotent)."""
        if self._callback not in gc.callbacks:
            gc.callbacks.append(self._callback)

    def stop(self) -> None:
        """Stop watching."""
        if self._callback in gc.callbacks:
            gc.callbacks.remove(self._callback)

    def _callback(self, phase: str, info: dict[str, Any]) -> None:
        if phase == "start":
            self._started = time.perf_counter()
            return
        if self._started is None:
            return
        elapsed = (time.perf_counter() - self._started) * 1e3
        self._started = None
        self.passes += 1
        self.oldest += info.get("generation") == 2
        self.total_ms += elapsed
        self.longest_ms = max(self.longest_ms, elapsed)

    def summary(self) -> str:
        """E.g. ``gc: 3 passes (0 of generation 2), longest 0.21 ms, 0.40 ms in all``."""
        return (
            f"gc: {self.passes} passes ({self.oldest} of generation 2), longest "
            f"{self.longest_ms:.2f} ms, {self.total_ms:.2f} ms in all"
        )


def parse_summary(text: str) -> tuple[int, int, float] | None:
    """``(passes, generation-2 passes, longest ms)`` of the last summary in a log, if any."""
    found = SUMMARY.findall(text)
    if not found:
        return None
    passes, oldest, longest = found[-1]
    return int(passes), int(oldest), float(longest)
