"""``facesynth bench smoothing``: less jitter with the shipped filters, some lag, seeded figures."""

from __future__ import annotations

import pytest


def test_bench_smoothing_reports_less_jitter_and_some_lag() -> None:
    from facesynth.app.bench.smoothing import bench_smoothing, format_smoothing

    result = bench_smoothing(seconds=4.0)
    rows = {(r["servo"], r["chain"]): r for r in result["rows"]}
    for servo in ("right_eyebrow", "right_eye_x"):
        raw, euro, shipped = (rows[(servo, c)] for c in ("unfiltered", "one euro", "shipped"))
        assert raw["step_50_ms"] == raw["step_90_ms"] == 0.0
        assert shipped["jitter_std_us"] < euro["jitter_std_us"] < 0.6 * raw["jitter_std_us"]
        assert 0.0 < euro["step_90_ms"] <= 200.0
    assert result == bench_smoothing(seconds=4.0)  # seeded: the same figures every run
    text = format_smoothing(result)
    assert "jitter std µs" in text and "right_eye_x      shipped" in text
    with pytest.raises(ValueError, match="has no servos \\['tail'\\]"):
        bench_smoothing(servos=["tail"])
