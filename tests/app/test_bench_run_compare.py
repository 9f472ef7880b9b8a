"""``facesynth bench run``: its options, the plain script's child process, and one real round
of ``facesynth run`` onto the emulated Maestro (without MediaPipe)."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

from facesynth.app.bench import run_compare
from facesynth.app.bench.run_compare import (
    WARMUP,
    Options,
    PlainScriptError,
    RunFailed,
    check_options,
    run_plain,
)
from facesynth.app.cli import main
from facesynth.app.data import sample_video
from facesynth.app.wiring import OptionError


def test_frames_default_to_300_after_the_warm_up() -> None:
    options = check_options(sample_video(), None, 3, None, None)
    assert (options.frames, options.runs, options.mediapipe_python) == (300, 3, None)
    # the bundled video has 472 frames: all of them after the warm-up
    assert check_options(sample_video(), 472 - WARMUP, 1, None, None).frames == 442


@pytest.mark.parametrize(
    ("frames", "runs", "python", "task", "message"),
    [
        (5, 0, None, None, "--runs must be at least 1"),
        (0, 1, None, None, "--frames must be at least 1"),
        (443, 1, None, None, "has 472 frames, so at most 442"),
        (5, 1, None, "x.task", "--mediapipe-task goes with --mediapipe-python"),
        (5, 1, sys.executable, None, "needs --mediapipe-task"),
        (5, 1, sys.executable, "/no/such.task", "task file not found"),
        (5, 1, "/no/python", "{task}", "not an executable file"),
        (5, 1, "{task}", "{task}", "not an executable file"),  # a file, not executable
    ],
)
def test_bad_options_are_refused_before_anything_runs(
    tmp_path: Path, frames: int, runs: int, python: str | None, task: str | None, message: str
) -> None:
    task_file = tmp_path / "face_landmarker.task"
    task_file.write_bytes(b"not opened here")
    python = python.replace("{task}", str(task_file)) if python else None
    task = task.replace("{task}", str(task_file)) if task else None
    with pytest.raises(OptionError, match=re.escape(message)):
        check_options(sample_video(), frames, runs, python, task)


def test_a_video_too_short_for_the_warm_up_is_refused(tmp_path: Path) -> None:
    with pytest.raises(OptionError, match="not a video of more than 30 frames"):
        check_options(sample_video().parent / "OpenFace_Test.csv", None, 1, None, None)
    with pytest.raises(OptionError, match="video not found"):
        check_options(tmp_path / "none.mp4", None, 1, None, None)


def _options(python: Path, task: Path) -> Options:
    return Options(sample_video(), 5, 1, str(python), str(task))


def test_a_python_without_mediapipe_is_one_clear_error(tmp_path: Path) -> None:
    task = tmp_path / "face_landmarker.task"
    task.write_bytes(b"x")
    # this venv has no mediapipe: the real script fails in it, and says why
    with pytest.raises(PlainScriptError, match="No module named 'mediapipe'"):
        run_plain(_options(Path(sys.executable), task))


@pytest.mark.parametrize(
    ("script", "message"),
    [
        ("echo 'no figures here'", "not its figures"),
        ("true", "printed nothing"),
        ("echo boom >&2; exit 3", r"failed in .* \(exit 3\): boom"),
    ],
)
def test_a_child_that_prints_no_figures_is_one_clear_error(
    tmp_path: Path, script: str, message: str
) -> None:
    python = tmp_path / "python"
    python.write_text(f"#!/bin/sh\n{script}\n")
    python.chmod(0o755)
    with pytest.raises(PlainScriptError, match=message):
        run_plain(_options(python, python))


@pytest.mark.slow
def test_one_real_round_without_mediapipe(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", "run", "--frames", "5", "--runs", "1"]) == 0
    out = capsys.readouterr().out
    assert "--driver maestro onto an emulated Mini Maestro 24 on a pty" in out
    row = re.search(r"^\s+1\s+(-?[\d.]+)\s+([\d.]+)\s+—.*?(\d+) commands \((\d+) bytes", out, re.M)
    assert row, out
    run_cpu, model, commands, device_bytes = row.groups()
    assert float(model) > 0
    assert int(commands) == WARMUP + 5
    assert int(device_bytes) >= 35 * (WARMUP + 5)  # Set Multiple Targets, 16 servos, a frame
    assert "the plain MediaPipe script was not run" in out
    assert f"run ≤ model calls + 2 ms: {float(run_cpu):.2f} ≤ {float(model) + 2:.2f} ms" in out


def test_without_a_checkout_run_records_to_a_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(run_compare, "FAKE_DEVICES", tmp_path / "no-checkout")
    with run_compare.maestro_on_a_pty(tmp_path) as output:
        assert output.args == ["--driver", "record", "--out", str(tmp_path / "commands.jsonl")]
        assert output.bytes_in() is None
        assert "record driver" in output.description


def test_a_run_that_fails_is_one_clear_error() -> None:
    with pytest.raises(RunFailed, match=r"facesynth run failed \(exit 2\): .*teleporter"):
        run_compare.run_once(sample_video(), 3, ["--driver", "teleporter"])
