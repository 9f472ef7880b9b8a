"""Heap trimming: freed heap that glibc keeps goes back to the system; memory in use stays."""

from __future__ import annotations

import ctypes
import ctypes.util
import threading

from facesynth.runtime.heap_trim import HeapTrimmer, resident_bytes

MB = 1024 * 1024
#: 48 MB in 64 KiB blocks: each below any mmap threshold, so they come from a glibc arena.
BLOCK, BLOCKS = 64 * 1024, 768

libc = ctypes.CDLL(ctypes.util.find_library("c"))
libc.malloc.restype = ctypes.c_void_p
libc.malloc.argtypes = (ctypes.c_size_t,)
libc.free.argtypes = (ctypes.c_void_p,)


def test_the_trimmer_finds_glibc_here() -> None:
    """The project's machines (Debian, Raspberry Pi OS) have glibc 2.33+: a trimmer that finds
    no C library here is a broken loader, not a platform to skip."""
    assert HeapTrimmer().available


def on_a_thread(body: object) -> None:
    """Run ``body`` on a new thread, as Zenoh's threads allocate (their own arena)."""
    worker = threading.Thread(target=body)  # type: ignore[arg-type]
    worker.start()
    worker.join()


def allocate(blocks: list[int]) -> None:
    for _ in range(BLOCKS):
        address = libc.malloc(BLOCK)
        ctypes.memset(address, 1, BLOCK)  # touched: resident
        blocks.append(address)


def free_all_but_the_last(blocks: list[int]) -> None:
    """Free every block but the last, which keeps glibc from giving back the arena's top."""
    for address in blocks[:-1]:
        libc.free(address)
    del blocks[:-1]


def test_freed_heap_a_burst_left_resident_goes_back_to_the_system() -> None:
    trimmer = HeapTrimmer(rise_bytes=16 * MB)
    blocks: list[int] = []
    before = resident_bytes()
    on_a_thread(lambda: allocate(blocks))
    on_a_thread(lambda: free_all_but_the_last(blocks))
    kept = resident_bytes()
    try:
        assert kept - before > 40 * MB  # glibc kept the freed blocks: this is the growth
        trim = trimmer.check()
        assert trim is not None
        assert trim.returned > 40 * MB, trim
        assert resident_bytes() - before < 8 * MB
        assert trimmer.check() is None  # nothing new: no second trim
    finally:
        for address in blocks:
            libc.free(address)


def test_memory_in_use_is_not_trimmed_and_a_rise_under_the_threshold_waits() -> None:
    trimmer = HeapTrimmer(rise_bytes=16 * MB)
    higher = HeapTrimmer(rise_bytes=64 * MB)
    blocks: list[int] = []
    on_a_thread(lambda: allocate(blocks))
    try:
        assert trimmer.check() is None  # 48 MB more resident, all of it in use
        on_a_thread(lambda: free_all_but_the_last(blocks))
        assert higher.check() is None  # 48 MB now idle: under a 64 MB rise
        trim = trimmer.check()  # and over a 16 MB one
        assert trim is not None and trim.returned > 40 * MB, trim
    finally:
        for address in blocks:
            libc.free(address)


def test_the_thread_trims_on_its_own_and_stops() -> None:
    trimmer = HeapTrimmer(interval_s=0.05, rise_bytes=16 * MB)
    blocks: list[int] = []
    assert trimmer.start()
    try:
        on_a_thread(lambda: allocate(blocks))
        on_a_thread(lambda: free_all_but_the_last(blocks))
        deadline = threading.Event()
        for _ in range(100):
            if trimmer.trims:
                break
            deadline.wait(0.05)
        assert trimmer.trims and trimmer.trims[0].returned > 40 * MB, trimmer.trims
    finally:
        trimmer.stop()
        for address in blocks:
            libc.free(address)
    assert not any(thread.name == "heap-trim" for thread in threading.enumerate())
