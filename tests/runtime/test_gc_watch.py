"""facesynth.runtime.gc_watch: collector passes counted and timed, and read back from a log."""

from __future__ import annotations

import gc

from facesynth.runtime.gc_watch import GcWatch, parse_summary


def test_passes_are_counted_and_timed_while_watching_only() -> None:
    watch = GcWatch()
    watch.start()
    watch.start()  # idempotent: one callback
    try:
        gc.collect(0)
        gc.collect(2)
    finally:
        watch.stop()
    assert watch.passes == 2 and watch.oldest == 1
    assert 0 < watch.longest_ms <= watch.total_ms
    gc.collect()
    assert watch.passes == 2, "stopped watching"


def test_the_summary_reads_back_from_a_log() -> None:
    watch = GcWatch(passes=3, oldest=1, longest_ms=0.254, total_ms=0.5)
    log = f"INFO something\nINFO {watch.summary()} after start-up\nINFO stopped\n"
    assert parse_summary(log) == (3, 1, 0.25)
    assert parse_summary("no collector line here") is None
