"""Inference runtimes as registered plugins: names, "auto", hosts without them, a new runtime."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from tracker_fixtures import REPO, VIDEO

from facesynth.app.cli import build_parser, main
from facesynth.runtime.plugins import PluginError
from facesynth.services.points.backends.tracker import TrackerConfig
from facesynth.services.points.tracker.model_files import MESH
from facesynth.services.points.tracker.runtimes import (
    RUNTIMES,
    backend_choices,
    load_model,
    resolve_backend,
    runtime_class,
)
from facesynth.services.points.tracker.runtimes.litert import LiteRTModel
from facesynth.services.points.tracker.runtimes.opencv import OpenCVModel


def test_the_runtimes_are_found_in_their_package() -> None:
    assert RUNTIMES.names() == ["litert", "opencv"]
    assert runtime_class("litert") is LiteRTModel and runtime_class("opencv") is OpenCVModel
    assert RUNTIMES.get("opencv").summary == "OpenCV DNN classic engine (NCHW input)."
    assert backend_choices() == ("auto", "litert", "opencv")


def test_auto_prefers_litert() -> None:
    assert LiteRTModel.priority > OpenCVModel.priority
    assert resolve_backend("auto") == "litert"


def test_an_unknown_runtime_is_a_one_line_error_listing_the_choices() -> None:
    with pytest.raises(PluginError) as info:
        load_model(MESH, "tflite")
    assert str(info.value) == "unknown backend 'tflite'; expected one of auto, litert, opencv"


def test_track_choices_come_from_the_registry(capsys: pytest.CaptureFixture[str]) -> None:
    parser = build_parser()
    command = ["track", "v.mp4", "--out", "o"]
    assert parser.parse_args([*command, "--inference", "opencv"]).inference == "opencv"
    with pytest.raises(SystemExit):
        parser.parse_args([*command, "--inference", "tflite"])
    err = capsys.readouterr().err.replace("'", "")  # Python 3.12 quotes the choices
    assert "invalid choice: tflite (choose from auto, litert, opencv)" in err


def test_the_tracker_backend_takes_the_registered_runtimes(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert TrackerConfig(inference="opencv").inference == "opencv"
    assert main(["points", "--inference", "tflite"]) == 2
    assert capsys.readouterr().err == (
        "facesynth points: error: backend tracker: unknown backend 'tflite'; "
        "expected one of auto, litert, opencv\n"
    )
    with pytest.raises(SystemExit):
        main(["points", "--help"])
    assert "tracker inference runtime: auto, litert, opencv" in " ".join(
        capsys.readouterr().out.split()
    )


def _run(script: str, pythonpath: list[Path]) -> str:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(map(str, [*pythonpath, REPO]))}
    done = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(script)],
        capture_output=True,
        text=True,
        env=env,
        timeout=60,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_runtimes_are_listed_on_hosts_without_opencv_or_litert() -> None:
    """The command line lists the runtimes where neither library is installed (servo hosts)."""
    out = _run(
        """
        import sys
        sys.modules["cv2"] = None  # "not installed": importing them raises ImportError
        sys.modules["ai_edge_litert"] = None
        from facesynth.app.cli import build_parser
        from facesynth.services.points.tracker.runtimes import backend_choices, resolve_backend
        build_parser()
        print(backend_choices())
        for name in ("auto", "litert"):
            try:
                resolve_backend(name)
            except ValueError as exc:
                print(exc)
        """,
        [],
    )
    assert out.splitlines() == [
        "('auto', 'litert', 'opencv')",
        "no inference runtime is installed (install facesynth[tracker])",
        "backend 'litert' requested but ai_edge_litert is not installed",
    ]


def test_a_runtime_from_another_distribution_is_usable_from_the_cli(tmp_path: Path) -> None:
    """One module plus an entry point, no edit in facesynth: the tracker and the CLI take it."""
    (tmp_path / "copy_runtime.py").write_text(
        textwrap.dedent(
            """
            import msgspec

            from facesynth.services.points.tracker.runtimes.base import RUNTIMES
            from facesynth.services.points.tracker.runtimes.opencv import OpenCVModel


            class CopyRuntime(msgspec.Struct, tag="opencv-copy", tag_field="runtime"):
                '''OpenCV under another name, shipped outside facesynth.'''


            @RUNTIMES.register(CopyRuntime)
            class OpenCVCopy(OpenCVModel):
                '''OpenCV under another name, shipped outside facesynth.'''
            """
        )
    )
    dist = tmp_path / "copy_runtime-1.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: copy-runtime\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text(
        "[facesynth.inference_runtimes]\nopencv-copy = copy_runtime\n"
    )
    out = _run(
        f"""
        from facesynth.app.cli import build_parser
        from facesynth.services.points.tracker import FaceTracker
        from facesynth.services.points.tracker.offline import iter_video_frames

        args = build_parser().parse_args(["track", "v.mp4", "--out", "o", "--inference",
                                          "opencv-copy"])
        tracker = FaceTracker(backend=args.inference, iris=False)
        result = tracker.process(next(iter_video_frames({str(VIDEO)!r}, 1)))
        print(tracker.backend, type(tracker.model.mesh_model.model).__name__, result.face)
        """,
        [tmp_path],
    )
    assert out.split() == ["opencv-copy", "OpenCVCopy", "True"]
