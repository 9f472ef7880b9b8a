"""``facesynth bench tracker``: per model and runtime stage timings, peak memory, the printed
table, the speed goals against MediaPipe's own trackers, and the helper's errors."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import pytest

from facesynth.app.bench.tracker import (
    MediaPipeError,
    bench_tracker,
    format_bench,
    run_mediapipe,
)
from facesynth.app.data import sample_video

VIDEO = sample_video()


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
