"""Big buffers go back to the system when freed, so a service's memory returns to its baseline.

glibc's ``malloc`` serves allocations above ``M_MMAP_THRESHOLD`` with their own mapping and
returns it on ``free``; but the threshold is dynamic: after a large mapped block is freed it
rises to that block's size (up to 32 MB), and later blocks that size come from the heap, where
freed memory stays. A service that refuses a burst of 18-22 MB messages (Zenoh reassembles each
in such a buffer before the subscription can look at its size) then kept ~45 MB it no longer
used (measured: control 60 -> 104 MB, 3 s after 20 messages of 22 MB). Fixing the threshold
keeps every block above it mapped, so it is unmapped when freed.

The free top of every arena goes back too. glibc gives an arena's free top back to the system
only once it is over ``M_TRIM_THRESHOLD``, and ``malloc_trim``
(:mod:`facesynth.runtime.heap_trim`) shrinks the main heap's top but never another arena's.
:func:`facesynth.app.tuning.keep_buffers`, which every stage process runs first, raises that
threshold to 16 MB, so the arena of each Zenoh thread that took a burst (a flood of refused
messages, a few 4 MB frames reassembled from fragments) kept up to 16 MB it no longer used, one
arena after another. Measured in the soak's chain on loopback (eclipse-zenoh 1.10.2): F gained
6.3, 1.9 and 0.4 MB of RSS over three floods of its input (40,000 refused messages in 4 s),
points 5.7 MB with a burst of three 4 MB frames, each time with the memory in use unchanged and
the growth free at the top of thread arenas, where ``malloc_trim`` gave back 0.3-0.8 MB of it.
Setting the threshold back to glibc's start value (:data:`TRIM_THRESHOLD`) gives such a top
back as soon as the burst's buffers are freed; buffers over :data:`MMAP_THRESHOLD` never come
from an arena here, so nothing a service reuses every frame is given back and taken again. The
same chain with the soak's faults every 12 s for 21 minutes: F +1.5 MB and P +1.1 MB instead of
+12.5 and +10.5 MB (+11.9 and +6.5 MB with ``MALLOC_ARENA_MAX=2`` instead), F's memory system
calls between faults unchanged (3-4 in 20 s).

``facesynth run`` keeps :func:`facesynth.app.tuning.keep_buffers`' thresholds and
``facesynth router`` a 4 MB trim threshold, by measurement (docs/benchmarks.md "The board
process beyond F's core"): ``run --fast`` on the bundled video showed no step of RSS either way
and took 2.5-5x the page faults with these settings; the router's steps after bursts went away
with a 128 KiB trim threshold, but each raw frame it forwards (as bytes: it has no shared
memory) was then faulted in again, 15-90 faults a 700 kB frame against none, and with 4 MB it
faults none in and keeps at most 4 MB free at each arena's top.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import sys

#: Allocations above this size get their own mapping (glibc's default start value).
MMAP_THRESHOLD = 128 * 1024
M_MMAP_THRESHOLD = -3  # from glibc's malloc.h
#: Free heap above this size at an arena's top goes back to the system (glibc's start value).
TRIM_THRESHOLD = 128 * 1024
M_TRIM_THRESHOLD = -1  # from glibc's malloc.h


def c_library() -> ctypes.CDLL | None:
    """This process's C library on Linux (its allocator is glibc's where these tunings apply),
    else ``None``; callers look up the functions they need and treat a missing one as "not
    glibc"."""
    if not sys.platform.startswith("linux"):
        return None
    name = ctypes.util.find_library("c")
    if name is None:
        return None
    try:
        return ctypes.CDLL(name)
    except OSError:
        return None


def return_big_allocations() -> bool:
    """Fix glibc's mmap and trim thresholds (see the module doc); False where there is no
    glibc."""
    libc = c_library()
    try:
        return (
            libc is not None
            and bool(libc.mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD))
            and bool(libc.mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD))
        )
    except AttributeError:  # a libc without mallopt (musl): nothing to do
        return False
