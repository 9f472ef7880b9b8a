"""facesynth.app.bench.face: the live page's cost per command, per page."""

from __future__ import annotations

from facesynth.app.bench.face import CASES, bench_face, format_face


def test_every_case_runs_and_reading_pages_get_every_face() -> None:
    result = bench_face(seconds=0.3, rate=50.0)
    rows = {row["case"]: row for row in result["rows"]}
    assert list(rows) == [case.name for case in CASES]
    for case in CASES:
        row = rows[case.name]
        assert row["commands"] == 15
        assert 0 < row["send_p50_us"] <= row["send_p99_us"]
        if case.readers:  # hello + every face (+ every frame), none lost by a reading page
            assert row["min_received"] == 1 + 15 * (2 if case.frames else 1)
        else:
            assert row["min_received"] is None
    text = format_face(result)
    assert "virtual, 16 pages" in text and "send p50 µs" in text
