"""``facesynth run --render`` stopped by Ctrl-C (issue 29): the video of the frames played so
far, or one line saying why the render was skipped; never a silent exit with nothing written.

The Ctrl-C tests run the real command in its own process on the bundled video, in real time,
and send it SIGINT as a terminal would.
"""

from __future__ import annotations

import json
import logging
import signal
import subprocess
import sys
import time
from pathlib import Path

import cv2
import pytest

from facesynth.app.cli import main
from facesynth.app.entry import INTERRUPTED
from facesynth.app.graph import DEFAULT_GRAPH, load_graph
from facesynth.app.render import render_run

ROOT = Path(__file__).resolve().parents[2]
#: Commands recorded before the first Ctrl-C (about a second of the bundled video).
PLAYED = 24
#: The bundled video's frames: an interrupted run plays fewer.
VIDEO_FRAMES = 472


def _start(folder: Path) -> subprocess.Popen[bytes]:
    argv = [sys.executable, "-m", "facesynth", "run", "--render", str(folder / "half.mp4")]
    argv += ["--out", str(folder / "c.jsonl"), "--listen", "tcp/127.0.0.1:0"]
    return subprocess.Popen(argv, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE)


def _frames_commanded(record: Path) -> int:
    """Commands in the record file that carry a frame (not the session marker, nor C's own
    steps between frames): the sensor has played at least as many frames."""
    count = 0
    for line in record.read_bytes().splitlines() if record.exists() else []:
        try:
            entry = json.loads(line)
        except ValueError:  # a line still being written
            continue
        count += isinstance(entry, dict) and entry.get("frame") is not None
    return count


def _interrupt_after_commands(process: subprocess.Popen[bytes], record: Path) -> None:
    """SIGINT once ``PLAYED`` frames were commanded (the run is under way)."""
    deadline = time.monotonic() + 120
    while _frames_commanded(record) < PLAYED:
        assert process.poll() is None, process.communicate()[1].decode()
        assert time.monotonic() < deadline, "no commands recorded in 120 s"
        time.sleep(0.05)
    process.send_signal(signal.SIGINT)


def _decoded_frames(path: Path) -> int:
    capture = cv2.VideoCapture(str(path))
    count = 0
    while capture.read()[0]:
        count += 1
    capture.release()
    return count


def test_ctrl_c_renders_the_frames_played_so_far(tmp_path: Path) -> None:
    """Before: exit 130, no video, no ``render`` key and not a word about it."""
    process = _start(tmp_path)
    _interrupt_after_commands(process, tmp_path / "c.jsonl")
    out, err = process.communicate(timeout=180)
    assert process.returncode == INTERRUPTED, err.decode()
    assert b"Traceback" not in err
    summary = json.loads(out)
    played = summary["frames"]
    assert PLAYED <= played < VIDEO_FRAMES
    assert summary["render"]["frames"] == played
    assert summary["render"]["out"] == str(tmp_path / "half.mp4")
    assert f"interrupted after {played} frames: rendering them to".encode() in err
    assert _decoded_frames(tmp_path / "half.mp4") == played  # a whole, playable video
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.jsonl", "half.mp4"]


def test_ctrl_c_again_while_rendering_skips_it_in_one_line(tmp_path: Path) -> None:
    process = _start(tmp_path)
    _interrupt_after_commands(process, tmp_path / "c.jsonl")
    assert process.stderr is not None
    lines = []
    for line in process.stderr:
        lines.append(line)
        if b"Ctrl-C again to skip" in line:
            process.send_signal(signal.SIGINT)
            break
    out, err = process.communicate(timeout=180)
    text = b"".join(lines).decode() + err.decode()
    assert process.returncode == INTERRUPTED, text
    assert "Traceback" not in text
    assert out.strip(), text
    summary = json.loads(out)
    assert summary["render"] == {"skipped": "interrupted again while rendering"}
    skipped = [line for line in text.splitlines() if "render skipped" in line]
    assert len(skipped) == 1, text
    assert skipped[0].endswith(
        f"render skipped: interrupted again while rendering ({tmp_path / 'half.mp4'} not written)"
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.jsonl"]  # no temporary left


def test_nothing_played_skips_the_render_in_one_line(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    out = tmp_path / "half.mp4"
    with caplog.at_level(logging.WARNING, logger="facesynth.render"):
        render = render_run(load_graph(DEFAULT_GRAPH), {}, out, frames=0, interrupted=True)
    assert render == {"skipped": "interrupted before the first frame was played"}
    assert [r.getMessage() for r in caplog.records] == [
        f"render skipped: interrupted before the first frame was played ({out} not written)"
    ]
    assert not out.exists()


def test_an_input_that_cannot_be_rendered_is_refused_before_the_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Before: the whole chain ran (the commands were written), then the render was refused."""
    commands = tmp_path / "c.jsonl"
    argv = ["run", "--loop", "--max-frames", "2", "--render", str(tmp_path / "o.mp4")]
    argv += ["--out", str(commands), "--listen", "tcp/127.0.0.1:0"]
    assert main(argv) == 2
    assert "facesynth run: error: a looping video never ends" in capsys.readouterr().err
    assert not commands.exists()
