"""facesynth.runtime.stats: counters, publication rate, capture-to-publish latency, memory."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path
from subprocess import PIPE
from typing import Any

import numpy as np
import pytest

from facesynth.runtime import codec, stats
from facesynth.runtime.stats import RATE_WINDOW_NS, StageStats
from facesynth.schemas.messages import ServiceStats

MS = 1_000_000
S = 1_000_000_000


def _stats() -> StageStats:
    return StageStats("features", "i1", "lab", window=100)


@pytest.mark.parametrize(
    ("times_ns", "now_ns", "rate"),
    [
        ([], 10 * S, 0.0),
        ([S], S, 0.0),
        ([S, 2 * S], 2 * S, 1.0),
        ([i * 40 * MS for i in range(26)], 25 * 40 * MS, 25.0),
        ([i * 100 * MS for i in range(11)], 2 * S, 5.0),  # 10 publications over 2 s
    ],
    ids=["nothing", "one", "two-1s-apart", "25hz", "10hz-then-silence"],
)
def test_rate(times_ns: list[int], now_ns: int, rate: float) -> None:
    s = _stats()
    for t in times_ns:
        s.record_published(0, now_ns=t)
    assert s.rate_hz(now_ns) == pytest.approx(rate)
    assert s.published == len(times_ns)


def test_rate_forgets_publications_older_than_the_window() -> None:
    s = _stats()
    for i in range(10):  # 10 Hz for one second, then silence
        s.record_published(0, now_ns=i * 100 * MS)
    assert s.rate_hz(900 * MS) == pytest.approx(10.0)
    assert s.rate_hz(900 * MS + RATE_WINDOW_NS + 1) == 0.0
    s.record_published(0, now_ns=20 * S)
    s.record_published(0, now_ns=20 * S + 500 * MS)
    assert s.rate_hz(20 * S + 500 * MS) == pytest.approx(2.0)
    assert len(s._published_at) == 2  # the old ones were pruned


def test_rate_is_zero_once_the_stage_stops_publishing() -> None:
    """Not the last publications spread over the window (a stopped sensor showed 3.6-7 Hz)."""
    s = _stats()
    for i in range(240):  # 24 Hz for 10 s
        s.record_published(0, now_ns=i * S // 24)
    last = 239 * S // 24
    assert s.rate_hz(last + S // 2) == pytest.approx(21.6, abs=0.1)
    assert s.rate_hz(last + stats.IDLE_NS + 1) == 0.0
    assert s.rate_hz(last + 3 * S) == 0.0
    assert s.snapshot(now_ns=last + 3 * S).idle_s == pytest.approx(3.0)


def test_a_slow_stage_is_idle_only_after_three_of_its_intervals() -> None:
    s = _stats()
    for i in range(10):  # 2 Hz, the last at 4.5 s
        s.record_published(0, now_ns=i * S // 2)
    assert s.rate_hz(5_900 * MS) == pytest.approx(7 / 4.9)  # 1.4 s since the last: not yet
    assert s.rate_hz(6 * S + 1) == 0.0  # three intervals (1.5 s) since the last
    assert _stats().snapshot(now_ns=S).idle_s is None  # nothing published yet


def test_latency_is_measured_from_capture() -> None:
    s = _stats()
    for latency_ms in range(1, 101):  # 1..100 ms
        s.record_published(t_capture_ns=1000 * S, now_ns=1000 * S + latency_ms * MS)
    snap = s.snapshot(now_ns=1000 * S + 200 * MS)
    assert snap.window == 100
    assert snap.latency_p50_ms == pytest.approx(50.5)
    assert snap.latency_p99_ms == pytest.approx(99.01)


def test_messages_without_capture_time_have_no_latency() -> None:
    s = _stats()
    s.record_published(t_capture_ns=0, now_ns=5 * S)
    snap = s.snapshot(now_ns=5 * S)
    assert snap.published == 1
    assert snap.window == 0
    assert snap.latency_p50_ms is None and snap.latency_p99_ms is None


def test_latency_window_keeps_the_latest() -> None:
    s = StageStats("points", "i", "lab", window=3)
    for latency_ms in (100, 100, 1, 2, 3):
        s.record_published(t_capture_ns=S, now_ns=S + latency_ms * MS)
    snap = s.snapshot(now_ns=2 * S)
    assert snap.window == 3
    assert snap.latency_p50_ms == pytest.approx(2.0)


def test_snapshot_carries_counters_and_is_a_valid_message() -> None:
    s = _stats()
    s.started_ns = 10 * S
    s.received, s.rejected, s.dropped = 7, 2, 1
    s.record_published(t_capture_ns=11 * S, now_ns=11 * S + 4 * MS)
    snap = s.snapshot(now_ns=13 * S, note="waiting")
    assert (snap.service, snap.instance, snap.rig) == ("features", "i1", "lab")
    assert (snap.received, snap.published, snap.rejected, snap.dropped) == (7, 1, 2, 1)
    assert snap.uptime_s == pytest.approx(3.0)
    assert snap.t_ns == 13 * S
    assert snap.note == "waiting"
    assert snap.rss_mb > 0 and snap.peak_rss_mb >= snap.rss_mb
    assert codec.decode(codec.encode(snap), ServiceStats) == snap


def test_memory_mb_is_plausible() -> None:
    rss, peak = stats.memory_mb()
    assert 1 < rss < 100_000
    assert peak >= rss


def test_memory_mb_without_proc(monkeypatch: pytest.MonkeyPatch) -> None:
    def no_proc(*args: object, **kwargs: object) -> None:
        raise OSError("no /proc")

    monkeypatch.setattr("builtins.open", no_proc)
    rss, peak = stats.memory_mb()
    assert rss == peak > 1


def test_memory_mb_of_another_process() -> None:
    script = "import sys; print('ready', flush=True); sys.stdin.read()"
    child = subprocess.Popen([sys.executable, "-c", script], stdin=PIPE, stdout=PIPE)
    try:
        assert child.stdout is not None and child.stdout.readline() == b"ready\n"
        rss, peak = stats.memory_mb(child.pid)
        assert 1 < rss <= peak < 100_000
    finally:
        child.communicate(b"", timeout=30)
    assert all(math.isnan(v) for v in stats.memory_mb(child.pid))  # gone: no figures


def test_memory_mb_of_another_process_without_proc(monkeypatch: pytest.MonkeyPatch) -> None:
    def no_proc(*args: object, **kwargs: object) -> None:
        raise OSError("no /proc")

    monkeypatch.setattr("builtins.open", no_proc)
    assert all(math.isnan(v) for v in stats.memory_mb(os.getpid()))


@pytest.mark.parametrize("size", [1, 2, 3, 4, 7, 100, 101, 599, 600])
def test_percentiles_are_numpys_to_the_bit(size: int) -> None:
    rng = np.random.default_rng(size)
    windows = [
        rng.gamma(2.0, 3.0, size) * 10.0,  # latencies: skewed, no two alike
        np.round(rng.normal(20.0, 5.0, size), 1),  # many ties
        rng.uniform(0.0, 1e-3, size),
        np.full(size, 12.5),
    ]
    for window in windows:
        values = [float(v) for v in window]
        quantiles = (0, 1, 25, 33, 50, 66.6, 75, 90, 99, 99.9, 100)
        assert stats.percentiles(values, quantiles) == [
            float(v) for v in np.percentile(window, quantiles)
        ]


def test_memory_mb_reads_the_two_lines_of_the_status_table() -> None:
    with open("/proc/self/status", encoding="ascii") as handle:
        fields = dict(line.split(":", 1) for line in handle if ":" in line)
    rss, peak = stats.memory_mb()
    before = int(fields["VmHWM"].split()[0]) / 1024
    assert before <= peak < before + 2  # the peak only grows (another thread may grow it)
    assert abs(rss - int(fields["VmRSS"].split()[0]) / 1024) < 2  # read a moment later


@pytest.mark.parametrize(
    "status",
    [b"Name:\tpython\nVmHWM:\t  10 kB\n", b"Name:\tpython\nVmRSS:\t\nVmHWM:\t10 kB\n", b""],
    ids=["no-rss-line", "no-number", "empty"],
)
def test_memory_mb_of_a_status_table_without_the_figures(
    status: bytes, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    fake = tmp_path / "status"
    fake.write_bytes(status)
    real_open = open

    def fake_open(path: object, *args: Any, **kwargs: Any) -> Any:
        return real_open(fake if str(path).startswith("/proc/") else path, *args, **kwargs)  # type: ignore[call-overload]

    monkeypatch.setattr("builtins.open", fake_open)
    assert all(math.isnan(v) for v in stats.memory_mb(os.getpid()))  # another's: no figures
    rss, peak = stats.memory_mb()  # this process's: its peak from getrusage
    assert rss == peak > 1
