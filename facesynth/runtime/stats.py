"""Running figures of one service: counts, rate, capture-to-publish latency, memory."""

from __future__ import annotations

import collections
import math
import resource
import sys
import time
from collections.abc import Iterable, Sequence

from facesynth.runtime.bus.link import LinkFigures
from facesynth.schemas.messages import ServiceStats

RATE_WINDOW_NS = 5_000_000_000
#: A service that has not published for this long (and for three of its recent intervals) is
#: idle: its rate is 0, not the count of its last publications spread over the window.
IDLE_NS = 1_000_000_000


def memory_mb(pid: int | None = None) -> tuple[float, float]:
    """Current and peak resident memory of a process (default: this one), in MB.

    Read from ``/proc/<pid>/status``. Where that cannot be read: for this process, its peak
    (``getrusage``) for both; for another process, NaN for both.
    """
    where = "self" if pid is None else pid
    try:
        with open(f"/proc/{where}/status", "rb") as handle:
            status = handle.read()
        return _kib(status, b"\nVmRSS:") / 1024, _kib(status, b"\nVmHWM:") / 1024
    except (OSError, ValueError):
        if pid is not None:
            return math.nan, math.nan
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        peak_mb = peak / (1024 * 1024) if sys.platform == "darwin" else peak / 1024
        return peak_mb, peak_mb


def _kib(status: bytes, field: bytes) -> int:
    """The number of kB of a ``/proc/<pid>/status`` line (``b"\\nVmRSS:"`` finds ``VmRSS: 123
    kB``); ``ValueError`` when the line is missing or holds no number. Only the two lines
    wanted are read (the whole table parsed took 3x as long, in every service's stats)."""
    start = status.index(field) + len(field)
    end = status.find(b"\n", start)
    words = status[start : end if end >= 0 else None].split()
    if not words:
        raise ValueError(f"no number on the {field.decode().strip()} line")
    return int(words[0])


def percentiles(values: Iterable[float], quantiles: Sequence[float]) -> list[float]:
    """The ``quantiles`` (percent) of ``values``, exactly as ``numpy.percentile``'s default
    (``linear``) method computes them (its index, weight and two-sided interpolation, in the
    same floating-point operations), in a third of the time for a stage's latency window:
    numpy's machinery costs more than sorting a few hundred numbers. ``values`` must be
    finite and not empty."""
    ordered = sorted(values)
    last = len(ordered) - 1
    out = []
    for quantile in quantiles:
        virtual = last * (quantile / 100)
        if virtual >= last:
            out.append(ordered[last])
            continue
        below = math.floor(virtual)
        gamma = virtual - below
        low, high = ordered[below], ordered[below + 1]
        diff = high - low
        out.append(high - diff * (1 - gamma) if gamma >= 0.5 else low + diff * gamma)
    return out


class StageStats:
    """Counters and a latency window for one service instance."""

    def __init__(self, service: str, instance: str, rig: str, window: int = 600) -> None:
        self.service = service
        self.instance = instance
        self.rig = rig
        self.started_ns = time.time_ns()
        self.received = 0
        self.published = 0
        self.rejected = 0
        self.dropped = 0
        #: Inputs dropped because their frame was captured too long ago (an upstream stall).
        self.stale = 0
        #: A line on the service's state, published with its stats (e.g. a servo board's link).
        self.note = ""
        self.latencies_ms: collections.deque[float] = collections.deque(maxlen=window)
        self._published_at: collections.deque[int] = collections.deque()
        self._last_published_ns: int | None = None

    def record_published(self, t_capture_ns: int, now_ns: int | None = None) -> None:
        """One message out; its latency is measured from its source frame's capture."""
        now = time.time_ns() if now_ns is None else now_ns
        self.published += 1
        if t_capture_ns > 0:
            self.latencies_ms.append((now - t_capture_ns) / 1e6)
        self._published_at.append(now)
        self._last_published_ns = now
        while self._published_at and now - self._published_at[0] > RATE_WINDOW_NS:
            self._published_at.popleft()

    def rate_hz(self, now_ns: int) -> float:
        """Publications per second over the last few seconds; 0 once the service is idle (no
        publication for :data:`IDLE_NS` and for three of its recent intervals)."""
        times = [t for t in self._published_at if now_ns - t <= RATE_WINDOW_NS]
        if len(times) < 2:
            return 0.0
        interval = (times[-1] - times[0]) / (len(times) - 1)
        if now_ns - times[-1] > max(IDLE_NS, 3 * interval):
            return 0.0
        span = max(now_ns - times[0], 1)
        return (len(times) - 1) * 1e9 / span

    def snapshot(
        self, now_ns: int | None = None, note: str = "", link: LinkFigures | None = None
    ) -> ServiceStats:
        """The current figures as a :class:`ServiceStats` message (with the router link's)."""
        now = time.time_ns() if now_ns is None else now_ns
        p50 = p99 = None
        if self.latencies_ms:
            p50, p99 = percentiles(self.latencies_ms, (50, 99))
        rss, peak = memory_mb()
        return ServiceStats(
            service=self.service,
            instance=self.instance,
            rig=self.rig,
            t_ns=now,
            uptime_s=(now - self.started_ns) / 1e9,
            received=self.received,
            published=self.published,
            dropped=self.dropped,
            rejected=self.rejected,
            rate_hz=self.rate_hz(now),
            latency_p50_ms=p50,
            latency_p99_ms=p99,
            rss_mb=rss,
            peak_rss_mb=peak,
            window=len(self.latencies_ms),
            note=note or self.note,
            router_connected=None if link is None else link.connected,
            router_losses=0 if link is None else link.losses,
            router_offline_s=0.0 if link is None else round(link.offline_s, 3),
            idle_s=self.idle_s(now),
            stale=self.stale,
        )

    def idle_s(self, now_ns: int) -> float | None:
        """Seconds since the last publication (``None`` before the first)."""
        if self._last_published_ns is None:
            return None
        return round(max(now_ns - self._last_published_ns, 0) / 1e9, 3)
