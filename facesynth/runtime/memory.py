"""Big buffers go back to the system when freed, so a service's memory returns to its baseline.

glibc's ``malloc`` serves allocations above ``M_MMAP_THRESHOLD`` with their own mapping and
returns it on ``free``; but the threshold is dynamic: after a large mapped block is freed it
rises to that block's size (up to 32 MB), and later blocks that size come from the heap, where
freed memory stays. A service that refuses a burst of 18-22 MB messages (Zenoh reassembles each
in such a buffer before the subscription can look at its size) then kept ~45 MB it no longer
used (measured: control 60 -> 104 MB, 3 s after 20 messages of 22 MB). Fixing the threshold
keeps every block above it mapped, so it is unmapped when freed.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import sys

#: Allocations above this size get their own mapping (glibc's default start value).
MMAP_THRESHOLD = 128 * 1024
M_MMAP_THRESHOLD = -3  # from glibc's malloc.h


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
    """Fix glibc's mmap threshold (see the module doc); False where there is no glibc."""
    libc = c_library()
    try:
        return libc is not None and bool(libc.mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD))
    except AttributeError:  # a libc without mallopt (musl): nothing to do
        return False
