"""A stage process's memory returns to its baseline: what a burst on one of its threads took
from the system goes back once freed (glibc's thresholds, :mod:`facesynth.runtime.memory`)."""

from __future__ import annotations

import json
import subprocess
import sys

#: Run in a process of its own, since glibc's thresholds are the whole process's. It sets up
#: glibc as a stage process does (``tune_process`` keeps buffers, then ``run_single`` returns
#: big allocations), after one burst with ``keep_buffers`` alone to show what that kept. A
#: burst: 8 MB in 64 KiB blocks (each under the mmap threshold, so it comes from an arena) on
#: threads of their own, as Zenoh's threads allocate, each in its own arena, all freed.
#: Prints the heap the arenas hold from the system (``mallinfo2().arena``) before any burst,
#: after the one with ``keep_buffers`` alone, and after three more with the stage's settings.
SCRIPT = """
import ctypes, json, threading
from facesynth.app.tuning import keep_buffers
from facesynth.runtime.memory import c_library, return_big_allocations

class MallInfo2(ctypes.Structure):
    _fields_ = [(name, ctypes.c_size_t) for name in (
        "arena ordblks smblks hblks hblkhd usmblks fsmblks uordblks fordblks keepcost".split())]

libc = c_library()
libc.malloc.restype = ctypes.c_void_p
libc.malloc.argtypes = (ctypes.c_size_t,)
libc.free.argtypes = (ctypes.c_void_p,)
libc.mallinfo2.restype = MallInfo2
BLOCK, BLOCKS = 64 * 1024, 128

def burst(start):
    start.wait()
    # A C array, not a list: a list's item array, grown by this thread, would come from its
    # arena too and, alive above the blocks until they are all freed, keep the top in use.
    blocks = (ctypes.c_void_p * BLOCKS)()
    for index in range(BLOCKS):
        blocks[index] = libc.malloc(BLOCK)
    for address in blocks:
        ctypes.memset(address, 1, BLOCK)
    for address in blocks:
        libc.free(address)

def bursts(count):
    start = threading.Barrier(count)
    threads = [threading.Thread(target=burst, args=(start,)) for _ in range(count)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    return libc.mallinfo2().arena

before = libc.mallinfo2().arena
keep_buffers()
kept = bursts(1)
return_big_allocations()
stage = bursts(3)
print(json.dumps({"before": before, "keep_buffers": kept, "stage": stage}))
"""

MB = 1024 * 1024


def test_a_burst_on_the_threads_of_a_stage_process_goes_back_to_the_system() -> None:
    done = subprocess.run(
        [sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=60, check=True
    )
    held = json.loads(done.stdout)
    # keep_buffers alone: the thread's arena keeps its free 8 MB top (what F and P grew by).
    assert held["keep_buffers"] - held["before"] > 7 * MB, held
    # A stage's settings: that top, and three arenas' bursts of 8 MB each, go back when freed.
    assert held["stage"] - held["before"] < 1 * MB, held
