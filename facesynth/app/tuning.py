"""How a facesynth process sets itself up for low latency: scheduling and memory reuse.

**Scheduling.** Each node may ask for a niceness (``nice``), a real-time priority
(``realtime``: ``SCHED_FIFO`` at that priority) and the cores it may run on (``cpus``). They
are applied to the whole process before it opens its Zenoh session or loads a model, so every
thread it starts later (Zenoh's, the inference runtime's) inherits them. On a machine shared with
other work, a real-time chain keeps its latency: measured with two busy processes competing for
the 2 cores, capture → command p50/p99 went from 16.9/45.7 ms to 8.0/10.4 ms
(``facesynth bench chain --sched normal,realtime``; figures in docs/benchmarks.md). A negative
``nice`` or any ``realtime`` needs ``CAP_SYS_NICE`` (root, ``setcap``, the container's
``cap_add: [SYS_NICE]``) or a matching ``RLIMIT_NICE``/``RLIMIT_RTPRIO`` (``ulimit -e/-r``);
Linux keeps 5 % of each second for other tasks whatever a real-time task does
(``/proc/sys/kernel/sched_rt_runtime_us``).

**Memory reuse.** glibc returns freed memory above 128 KiB to the kernel at once; a service
that handles a 700 KB raw frame per message then takes ~170 page faults per buffer, every
frame (the sensor spent 40 % of its CPU time in the kernel that way). :func:`keep_buffers`
raises glibc's thresholds so such buffers are reused from the heap, while anything above
``MMAP_THRESHOLD`` still goes straight back to the kernel when freed and at most
``TRIM_THRESHOLD`` of free heap is kept.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import logging
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

from facesynth.runtime.memory import c_library

log = logging.getLogger("facesynth")

#: glibc ``mallopt`` parameters (malloc.h).
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
#: Buffers up to this size come from (and return to) the heap: a 1280x720 raw frame is 2.7 MB.
MMAP_THRESHOLD = 4 * 1024 * 1024
#: Free heap kept for reuse before it is given back to the kernel.
TRIM_THRESHOLD = 16 * 1024 * 1024
#: The router's: with it a forwarded raw frame's buffer is reused as with 16 MB (no page
#: faults), and after a burst each of its Zenoh threads' arenas keeps at most 4 MB of free top
#: instead of 16 (docs/benchmarks.md).
ROUTER_TRIM_THRESHOLD = 4 * 1024 * 1024
#: The router's heap trimmer trims once its idle memory stands this much above its lowest
#: (:class:`facesynth.runtime.heap_trim.HeapTrimmer`): two arenas' free tops.
ROUTER_TRIM_RISE = 2 * ROUTER_TRIM_THRESHOLD


class SchedulingError(ValueError):
    """A scheduling request the system refuses or that makes no sense."""


@dataclass(frozen=True)
class Scheduling:
    """What a process asks of the scheduler; ``None`` / empty leaves a setting alone."""

    nice: int | None = None
    realtime: int | None = None
    cpus: tuple[int, ...] = field(default_factory=tuple)

    @property
    def requested(self) -> bool:
        """Whether anything is asked for."""
        return self.nice is not None or self.realtime is not None or bool(self.cpus)

    def describe(self) -> str:
        """E.g. ``realtime 10, cpus 1``."""
        parts = []
        if self.realtime is not None:
            parts.append(f"real-time priority {self.realtime} (SCHED_FIFO)")
        if self.nice is not None:
            parts.append(f"nice {self.nice}")
        if self.cpus:
            parts.append(f"cpus {','.join(map(str, self.cpus))}")
        return ", ".join(parts) or "default scheduling"


def combined(requests: Iterable[Scheduling]) -> Scheduling:
    """One process running several nodes: the most demanding request of each kind (lowest
    nice, highest real-time priority) and every core any of them may use."""
    chosen = list(requests)
    nices = [r.nice for r in chosen if r.nice is not None]
    realtimes = [r.realtime for r in chosen if r.realtime is not None]
    cpus = sorted({cpu for r in chosen for cpu in r.cpus})
    return Scheduling(
        nice=min(nices) if nices else None,
        realtime=max(realtimes) if realtimes else None,
        cpus=tuple(cpus),
    )


def apply_scheduling(request: Scheduling, pid: int = 0) -> None:
    """Apply ``request`` to process ``pid`` (0: this one), or raise :class:`SchedulingError`."""
    if request.cpus:
        _apply_cpus(request.cpus, pid)
    if request.nice is not None:
        _apply_nice(request.nice, pid)
    if request.realtime is not None:
        _apply_realtime(request.realtime, pid)


def _apply_cpus(cpus: Sequence[int], pid: int) -> None:
    if not hasattr(os, "sched_setaffinity"):
        raise SchedulingError("--cpus needs Linux (sched_setaffinity)")
    available = sorted(os.sched_getaffinity(0))
    unknown = [cpu for cpu in cpus if cpu not in available]
    if unknown:
        raise SchedulingError(
            f"--cpus {','.join(map(str, cpus))}: no core {','.join(map(str, unknown))} here "
            f"(this process may use {','.join(map(str, available))})"
        )
    os.sched_setaffinity(pid, set(cpus))


def _apply_nice(nice: int, pid: int) -> None:
    if not -20 <= nice <= 19:
        raise SchedulingError(f"--nice {nice}: must be within -20..19")
    try:
        os.setpriority(os.PRIO_PROCESS, pid, nice)
    except PermissionError:
        raise SchedulingError(
            f"--nice {nice}: not permitted (a negative niceness needs CAP_SYS_NICE, root, or "
            "RLIMIT_NICE: ulimit -e)"
        ) from None


def _apply_realtime(priority: int, pid: int) -> None:
    if not hasattr(os, "SCHED_FIFO"):
        raise SchedulingError("--realtime needs Linux (SCHED_FIFO)")
    low, high = os.sched_get_priority_min(os.SCHED_FIFO), os.sched_get_priority_max(os.SCHED_FIFO)
    if not low <= priority <= high:
        raise SchedulingError(f"--realtime {priority}: must be within {low}..{high}")
    try:
        os.sched_setscheduler(pid, os.SCHED_FIFO, os.sched_param(priority))
    except PermissionError:
        raise SchedulingError(
            f"--realtime {priority}: not permitted (real-time scheduling needs CAP_SYS_NICE, "
            "root, a container with cap_add: [SYS_NICE], or RLIMIT_RTPRIO: ulimit -r)"
        ) from None


def keep_buffers(trim_threshold: int = TRIM_THRESHOLD) -> bool:
    """Let glibc reuse freed buffers of up to :data:`MMAP_THRESHOLD` instead of unmapping them,
    keeping up to ``trim_threshold`` of free heap at the top of each arena (see the module
    docstring); ``False`` where the C library is not glibc."""
    libc = c_library()
    try:
        mallopt = libc.mallopt if libc is not None else None
    except AttributeError:
        mallopt = None
    if mallopt is None:
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    return bool(
        mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD) and mallopt(_M_TRIM_THRESHOLD, trim_threshold)
    )


def tune_process(nodes: Iterable[Any]) -> None:
    """Set this process up for the nodes it runs: buffer reuse, and their scheduling requests
    (the most demanding of each kind, see :mod:`facesynth.app.tuning`)."""
    keep_buffers()
    request = combined(Scheduling(node.nice, node.realtime, tuple(node.cpus)) for node in nodes)
    if request.requested:
        apply_scheduling(request)
        log.info("scheduling: %s", request.describe())
