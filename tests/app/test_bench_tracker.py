"""``facesynth bench tracker``: per-runtime stage timings, peak memory, the printed table."""

from __future__ import annotations

import math

import pytest

from facesynth.app.bench.tracker import bench_tracker, format_bench
from facesynth.app.data import sample_video

VIDEO = sample_video()


def test_bench_tracker() -> None:
    result = bench_tracker(VIDEO, backends=("litert", "opencv"), frames=40)
    assert result["size"] == (640, 360) and result["cv2_threads"] == 1
    assert 0 < result["peak_rss_mb"] < 1000
    for name in ("litert", "opencv"):
        r = result["backends"][name]
        assert r["frames"] == r["faces"] == 40 and r["detector_runs"] == 2
        for stage in ("detect", "mesh", "iris", "mesh_iris", "tracker"):
            s = r[stage]
            assert s["n"] > 0 and 0 < s["median"] <= s["p99"] < 1000, (name, stage)
        assert r["mesh_iris"]["n"] == r["mesh"]["n"] == r["iris"]["n"]
        assert r["mesh_iris"]["mean"] == pytest.approx(r["mesh"]["mean"] + r["iris"]["mean"])
        assert math.isclose(r["fps"], 1000 / r["tracker"]["median"])
    text = format_bench(result)
    assert "litert" in text and "opencv" in text and "mesh_iris" in text
    assert "goal mesh+iris median <= 2.0 ms" in text
