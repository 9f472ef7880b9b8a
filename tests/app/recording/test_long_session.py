"""A 10-minute, 30 fps session through the real writer keeps its memory flat."""

from __future__ import annotations

from pathlib import Path

import pytest

from facesynth.app.bench.recording import record_session, sample_jpegs
from facesynth.app.recording.check import scan

#: The bound this test holds the writer to: RSS may grow by at most this much from minute 1
#: to minute 10 (the writer keeps one small index record per chunk; 600 chunks here).
RSS_GROWTH_BOUND_MB = 4.0


@pytest.mark.slow
def test_ten_minutes_at_30_fps_stay_within_the_memory_bound(tmp_path: Path) -> None:
    path = tmp_path / "long.mcap"
    result = record_session(path, 10.0, 30.0, sample_jpegs((64, 48)), (64, 48), mesh=False)
    assert (
        result["messages"] == 10 * 60 * 30 * 5 + 10 * 60 * 5
    )  # five stages a frame, stats every s
    minutes = result["per_minute"]
    assert len(minutes) == 10
    growth = minutes[-1]["rss_mb"] - minutes[0]["rss_mb"]
    assert growth < RSS_GROWTH_BOUND_MB, f"RSS grew {growth:.1f} MB over 9 minutes: {minutes}"
    assert result["chunks"] >= 590, "chunks are cut every second of session time"
    check = scan(path)
    assert check.complete and check.messages >= result["messages"]
