"""Offline video tracking to JSON Lines, corrupt videos, and the benchmark."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from tracker_fixtures import VIDEO, VIDEO_FRAMES, TrackedVideo

from facesynth.app.bench.tracker import MediaPipeError, bench_tracker, format_bench, run_mediapipe
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
    result = bench_tracker(VIDEO, backends=("litert", "opencv"), frames=40, repeat=2)
    assert result["size"] == (640, 360) and result["cv2_threads"] == 1
    assert 0 < result["peak_rss_mb"] < 1000 and result["repeat"] == 2
    assert set(result["results"]) == {"fast/litert", "fast/opencv", "full/litert", "full/opencv"}
    for key, r in result["results"].items():
        model = key.split("/")[0]
        extra = "iris" if model == "fast" else "blendshapes"
        assert r["model"] == model and r["frames"] == r["faces"] == 40
        assert r["detector_runs"] == 2
        for stage in ("detect", "mesh", extra, "models", "tracker"):
            s = r[stage]
            assert s["n"] > 0 and 0 < s["median"] <= s["p99"] < 1000, (key, stage)
        assert r["models"]["n"] == r["mesh"]["n"] == r[extra]["n"]
        assert math.isclose(r["fps"], 1000 / r["tracker"]["median"])
    text = format_bench(result)
    assert "fast/litert" in text and "full/opencv" in text and "blendshapes" in text
    assert "goal full: >= 1.5x faster than MediaPipe Face Landmarker" in text
    assert "no MediaPipe figure" in text


def _with_mediapipe(result: dict, landmarker_ms: float, mesh_ms: float) -> dict:
    def figures(ms: float) -> dict:
        stats = {"median": ms, "p99": ms, "mean": ms, "n": 9}
        return {"per_frame_ms": stats, "faces": 9, "frames": 9}

    return {
        **result,
        "mediapipe": {
            "mediapipe": "0.10.21",
            "face_landmarker": figures(landmarker_ms),
            "face_mesh_refined": figures(mesh_ms),
        },
    }


def test_bench_goals_compare_with_mediapipe() -> None:
    result = bench_tracker(VIDEO, backends=("litert",), frames=12)
    full = result["results"]["full/litert"]["tracker"]["median"]
    fast = result["results"]["fast/litert"]["tracker"]["median"]
    met = format_bench(_with_mediapipe(result, full * 1.6, fast * 1.1))
    assert "(goal >= 1.5x: met)" in met and "(goal >= 1x: met)" in met
    assert "MediaPipe Face Landmarker task" in met and "face_mesh_refined" in met
    missed = format_bench(_with_mediapipe(result, full * 0.75, fast * 0.5))
    assert "1.5x: NOT met, missed by 2.00x" in missed and "1x: NOT met, missed by 2.00x" in missed


def test_bench_mediapipe_helper_errors(tmp_path: Path) -> None:
    task = tmp_path / "face_landmarker.task"
    with pytest.raises(MediaPipeError, match="task file not found"):
        run_mediapipe(sys.executable, str(task), VIDEO, 5, 1)
    task.write_bytes(b"not a task")
    with pytest.raises(MediaPipeError, match="cannot run"):
        run_mediapipe(str(tmp_path / "no-python"), str(task), VIDEO, 5, 1)
    # this interpreter has no mediapipe: the helper fails and says so
    with pytest.raises(MediaPipeError, match="MediaPipe helper failed"):
        run_mediapipe(sys.executable, str(task), VIDEO, 5, 1)
    with pytest.raises(MediaPipeError, match="needs --mediapipe-task"):
        bench_tracker(VIDEO, backends=("litert",), frames=5, mediapipe_python=sys.executable)
    with pytest.raises(ValueError, match="--repeat"):
        bench_tracker(VIDEO, backends=("litert",), frames=5, repeat=0)
