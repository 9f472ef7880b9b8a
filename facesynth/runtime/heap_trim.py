"""Free heap goes back to the system: a thread trims glibc's heap after the process has grown.

A message Zenoh reassembles from fragments is collected in many small buffers on Zenoh's own
threads, each thread allocating from its own glibc arena. Once the message is delivered or
refused those buffers are free, but glibc keeps the pages: it only gives back the free top of
the main heap, never free chunks inside an arena. Measured on a Zenoh router here
(eclipse-zenoh 1.10.2): three 22 MB messages to a subscriber left 37-44 MB of free heap resident
with 6 MB of the heap in use, and ``malloc_trim(0)`` gave 30 MB of it back in 4-22 ms. Leaving
glibc's mmap threshold dynamic (no :func:`facesynth.app.tuning.keep_buffers`) kept 33 MB free
instead, since no single buffer is big, and ``MALLOC_ARENA_MAX=1`` 22 MB. With the trimmer,
``facesynth router`` peaked at 82-102 MB during each burst and was back at 61 MB (its level
before) within 5 s.

:class:`HeapTrimmer` checks every :data:`INTERVAL_S` seconds whether the process's idle
memory (resident anonymous memory that ``malloc`` has not handed out) stands :data:`RISE_BYTES`
above the lowest it has been, and has grown by :data:`RETRIM_BYTES` since its last trim; only
then it calls ``malloc_trim``: a steady service never trims (a buffer it reuses each frame
stays), one that held a burst returns it within seconds, and growth that is memory in use (a
cache) never counts. The level is the lowest ever, not the one the last trim left: a trim
cannot return a buffer still in use, and measuring from what it left let a router climb 14 MB
a burst (31.6 -> 57.3 MB anonymous over four bursts of 18 MB messages, each round under the
rise, measured here with eclipse-zenoh 1.10.2); the second condition keeps a process whose
idle memory cannot go lower from trimming every few seconds for nothing. ``facesynth
router``, every stage process and ``facesynth run`` (through its embedded router) run one.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import logging
import threading
from dataclasses import dataclass
from typing import Any, Final

from facesynth.runtime.memory import c_library

log = logging.getLogger("facesynth")

#: How often the thread looks (seconds).
INTERVAL_S: Final = 5.0
#: Growth of resident memory (and of free heap) that is worth a trim (bytes): as much free heap
#: as :func:`facesynth.app.tuning.keep_buffers` lets glibc keep for reuse.
RISE_BYTES: Final = 16 * 1024 * 1024
#: Growth since the last trim that is worth another once idle memory stands ``RISE_BYTES`` above
#: its lowest (bytes).
RETRIM_BYTES: Final = 4 * 1024 * 1024


class _MallInfo2(ctypes.Structure):
    """glibc's ``struct mallinfo2`` (glibc 2.33 and later)."""

    _fields_ = [
        (name, ctypes.c_size_t)
        for name in (
            "arena",
            "ordblks",
            "smblks",
            "hblks",
            "hblkhd",
            "usmblks",
            "fsmblks",
            "uordblks",
            "fordblks",
            "keepcost",
        )
    ]


def _glibc() -> Any | None:
    """The C library when it is glibc with ``malloc_trim`` and ``mallinfo2`` (2.33 and later),
    else ``None`` (musl, macOS, an older glibc)."""
    libc = c_library()
    if libc is None:
        return None
    try:
        trim = libc.malloc_trim
        info = libc.mallinfo2
    except AttributeError:
        return None
    trim.argtypes = (ctypes.c_size_t,)
    trim.restype = ctypes.c_int
    info.restype = _MallInfo2
    return libc


def resident_bytes() -> int:
    """This process's resident anonymous memory (bytes: ``RssAnon`` in ``/proc/self/status``),
    where freed heap that glibc keeps shows; 0 where there is no such line."""
    with open("/proc/self/status", encoding="ascii") as status:
        for line in status:
            if line.startswith("RssAnon:"):
                return int(line.split()[1]) * 1024
    return 0


@dataclass(frozen=True)
class Trim:
    """One trim: resident memory before and after it (bytes)."""

    before: int
    after: int

    @property
    def returned(self) -> int:
        """Bytes given back (never negative)."""
        return max(0, self.before - self.after)


class HeapTrimmer:
    """Gives free heap back to the system after the process has grown (see the module doc).

    What it watches is the *idle* memory: resident anonymous memory minus the heap glibc has
    handed out (``mallinfo2``), which grows when freed heap stays resident and not when memory
    in use does. :meth:`check` is one look (called by the thread :meth:`start` runs, or
    directly); the thread is a daemon and :meth:`stop` ends it. ``malloc_trim`` runs without the
    GIL (``ctypes``), so the event loop keeps running while it does."""

    def __init__(
        self,
        *,
        interval_s: float = INTERVAL_S,
        rise_bytes: int = RISE_BYTES,
        retrim_bytes: int = RETRIM_BYTES,
    ) -> None:
        self.interval_s = interval_s
        self.rise_bytes = rise_bytes
        self.retrim_bytes = retrim_bytes
        self.trims: list[Trim] = []
        self._libc = _glibc()
        start = self.idle_bytes() if self._libc is not None else 0
        self._lowest = start  # the lowest idle memory seen
        self._left = start  # the lowest since the last trim (what it left, or less)
        self._stopped = threading.Event()
        self._thread: threading.Thread | None = None

    @property
    def available(self) -> bool:
        """Whether this C library can trim (glibc 2.33 or later, on Linux)."""
        return self._libc is not None

    def idle_bytes(self) -> int:
        """Resident anonymous memory not handed out by glibc's ``malloc`` (bytes): free heap
        still resident, plus what never came from ``malloc`` (stacks, Python's own arenas)."""
        if self._libc is None:
            return 0
        info = self._libc.mallinfo2()
        return resident_bytes() - int(info.uordblks) - int(info.hblkhd)

    def check(self) -> Trim | None:
        """Trim if idle memory stands ``rise_bytes`` above the lowest it has been and grew by
        ``retrim_bytes`` since the last trim (or the start); the trim done, or ``None``."""
        if self._libc is None:
            return None
        idle = self.idle_bytes()
        self._lowest = min(self._lowest, idle)
        self._left = min(self._left, idle)
        if idle - self._lowest < self.rise_bytes or idle - self._left < self.retrim_bytes:
            return None
        before = resident_bytes()
        self._libc.malloc_trim(0)
        trim = Trim(before, resident_bytes())
        self._left = self.idle_bytes()
        self.trims.append(trim)
        log.info(
            "returned %.1f MB of free heap to the system (anonymous resident %.1f -> %.1f MB)",
            trim.returned / 1e6,
            trim.before / 1e6,
            trim.after / 1e6,
        )
        return trim

    def start(self) -> bool:
        """Start checking every ``interval_s`` seconds; ``False`` where nothing can be trimmed."""
        if self._libc is None or self._thread is not None:
            return self._thread is not None
        self._thread = threading.Thread(target=self._run, name="heap-trim", daemon=True)
        self._thread.start()
        return True

    def stop(self) -> None:
        """Stop the thread (a no-op when it never started)."""
        self._stopped.set()
        if self._thread is not None:
            self._thread.join(timeout=self.interval_s + 1.0)
            self._thread = None

    def _run(self) -> None:
        while not self._stopped.wait(self.interval_s):
            try:
                self.check()
            except OSError as exc:  # /proc unreadable: stop looking rather than spin on it
                log.warning("heap trimming stopped: %s", exc)
                return
