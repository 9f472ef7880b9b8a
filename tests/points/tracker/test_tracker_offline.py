"""Offline video tracking to JSON Lines, corrupt videos, and the benchmark."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from tracker_fixtures import VIDEO, VIDEO_FRAMES, TrackedVideo

from facesynth.app.bench.tracker import bench_tracker, format_bench
from services.points.tracker import FaceTracker, VideoError, track_video
from services.points.tracker.offline import iter_video_frames


def test_track_video_writes_one_line_per_frame(
    tmp_path: Path, tracker: FaceTracker, tracked_video: TrackedVideo
) -> None:
    out = tmp_path / "sub" / "points.jsonl"
    summary = track_video(VIDEO, out, tracker=tracker)
    assert summary["frames"] == summary["faces"] == VIDEO_FRAMES
    assert summary["lost_frames"] == []
    assert summary["backend"] == "litert" and summary["detector_runs"] == 16
    assert 0 < summary["tracker_ms_median"] <= summary["tracker_ms_p99"]
    lines = out.read_text(encoding="utf-8").splitlines()
    assert len(lines) == VIDEO_FRAMES
    assert [p.name for p in out.parent.iterdir()] == ["points.jsonl"]  # no temp file left
    for i, line in enumerate(lines):
        rec = json.loads(line)
        assert list(rec) == ["frame", "face", "mesh", "iris", "ibug68"]
        assert rec["frame"] == i and rec["face"] is True
        ref = tracked_video.results[i]
        for key, n in (("mesh", 468), ("iris", 10), ("ibug68", 68)):
            pts = np.array(rec[key])
            assert pts.shape == (n, 2)
            np.testing.assert_allclose(pts, getattr(ref, key)[:, :2], atol=0.0051)
            assert np.allclose(pts * 100, np.round(pts * 100), atol=1e-6)  # 2 decimals


def test_no_face_lines_are_null(tmp_path: Path, tracker: FaceTracker) -> None:
    from services.points.tracker.offline import result_to_record

    r = tracker.process(np.zeros((120, 160, 3), np.uint8))
    assert result_to_record(7, r) == {
        "frame": 7,
        "face": False,
        "mesh": None,
        "iris": None,
        "ibug68": None,
    }


def _truncated(p: Path) -> None:
    data = VIDEO.read_bytes()
    p.write_bytes(data[: len(data) // 2])


def _header_only(p: Path) -> None:
    p.write_bytes(VIDEO.read_bytes()[:5000])


def _garbage(p: Path) -> None:
    p.write_bytes(b"\x00garbage, not a video\xff" * 5000)


def _zeroed_middle(p: Path) -> None:
    data = bytearray(VIDEO.read_bytes())
    data[400_000:600_000] = bytes(200_000)
    p.write_bytes(bytes(data))


def _empty(p: Path) -> None:
    p.write_bytes(b"")


def _missing(p: Path) -> None:
    pass


@pytest.mark.parametrize(
    "make, message",
    [
        (_truncated, "truncated"),
        (_header_only, "cannot open"),
        (_garbage, "cannot open"),
        (_zeroed_middle, "truncated or corrupt"),
        (_empty, "cannot open"),
        (_missing, "not found"),
    ],
)
def test_corrupt_video_is_a_clear_error(
    tmp_path: Path, tracker: FaceTracker, make: object, message: str
) -> None:
    video = tmp_path / "bad.mp4"
    make(video)  # type: ignore[operator]
    out = tmp_path / "out" / "points.jsonl"
    out.parent.mkdir()
    out.write_text("previous result\n", encoding="utf-8")
    with pytest.raises(VideoError, match=message) as info:
        track_video(video, out, tracker=tracker)
    assert isinstance(info.value, ValueError)
    # the previous output is untouched and no temporary file is left behind
    assert out.read_text(encoding="utf-8") == "previous result\n"
    assert [p.name for p in out.parent.iterdir()] == ["points.jsonl"]


def test_iter_video_frames_limit() -> None:
    frames = list(iter_video_frames(VIDEO, max_frames=3))
    assert len(frames) == 3 and frames[0].shape == (360, 640, 3)


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
