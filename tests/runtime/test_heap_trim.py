"""Heap trimming: freed heap that glibc keeps goes back to the system; memory in use stays."""

from __future__ import annotations

import ctypes
import ctypes.util
import mmap
import threading

from facesynth.runtime.heap_trim import HeapTrimmer, resident_bytes

MB = 1024 * 1024
#: 48 MB in 64 KiB blocks: each below any mmap threshold, so they come from a glibc arena.
BLOCK, BLOCKS = 64 * 1024, 768

libc = ctypes.CDLL(ctypes.util.find_library("c"))
libc.malloc.restype = ctypes.c_void_p
libc.malloc.argtypes = (ctypes.c_size_t,)
libc.free.argtypes = (ctypes.c_void_p,)
libc.malloc_trim.argtypes = (ctypes.c_size_t,)


def from_a_trimmed_heap() -> None:
    """Give back the free heap the tests before left (a test worker's heap is shaped by every
    file it ran), so a burst takes new pages instead of reusing free ones, and a first trim
    returns only what the test made."""
    libc.malloc_trim(0)


def test_the_trimmer_finds_glibc_here() -> None:
    """The project's machines (Debian, Raspberry Pi OS) have glibc 2.33+: a trimmer that finds
    no C library here is a broken loader, not a platform to skip."""
    assert HeapTrimmer().available


def on_a_thread(body: object) -> None:
    """Run ``body`` on a new thread, as Zenoh's threads allocate (their own arena)."""
    worker = threading.Thread(target=body)  # type: ignore[arg-type]
    worker.start()
    worker.join()


def allocate(blocks: list[int], count: int = BLOCKS) -> None:
    for _ in range(count):
        address = libc.malloc(BLOCK)
        ctypes.memset(address, 1, BLOCK)  # touched: resident
        blocks.append(address)


def free_all_but_the_last(blocks: list[int]) -> None:
    """Free every block but the last, which keeps glibc from giving back the arena's top."""
    for address in blocks[:-1]:
        libc.free(address)
    del blocks[:-1]


def test_freed_heap_a_burst_left_resident_goes_back_to_the_system() -> None:
    from_a_trimmed_heap()
    trimmer = HeapTrimmer(rise_bytes=16 * MB)
    blocks: list[int] = []
    before = resident_bytes()
    on_a_thread(lambda: allocate(blocks))
    on_a_thread(lambda: free_all_but_the_last(blocks))
    kept = resident_bytes()
    try:
        # glibc kept the freed blocks (most of the 48 MB: an arena the thread reuses may have
        # held free pages already, which the burst took first and which a trim never returns)
        assert kept - before > 16 * MB
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


def test_a_trim_measures_from_the_lowest_level_not_from_what_the_last_trim_left() -> None:
    """Idle memory a trim cannot return (here a touched anonymous mapping, as Python's own
    arenas are) does not move the level a later burst is measured from: a burst of 12 MB on top
    of it is trimmed although it is under the 16 MB rise, and memory that cannot go lower is not
    trimmed again and again."""
    from_a_trimmed_heap()
    trimmer = HeapTrimmer(rise_bytes=16 * MB, retrim_bytes=4 * MB)
    untrimmable = mmap.mmap(-1, 20 * MB, flags=mmap.MAP_PRIVATE | mmap.MAP_ANONYMOUS)
    view = ctypes.c_char.from_buffer(untrimmable)
    ctypes.memset(ctypes.addressof(view), 1, 20 * MB)  # touched: resident, never malloc's
    del view  # (no 20 MB bytes object on the way: it could come from the heap)
    blocks: list[int] = []
    try:
        first = trimmer.check()
        assert first is not None and first.returned < 4 * MB, first  # nothing it can give back
        assert trimmer.check() is None  # no new growth: not again
        on_a_thread(lambda: allocate(blocks, 192))  # 12 MB
        on_a_thread(lambda: free_all_but_the_last(blocks))
        trim = trimmer.check()
        assert trim is not None and trim.returned > 10 * MB, trim
    finally:
        untrimmable.close()
        for address in blocks:
            libc.free(address)
