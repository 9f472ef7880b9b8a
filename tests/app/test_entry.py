"""Ctrl-C early in `facesynth run` (issue 20): exit 130, no traceback, even while importing."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from facesynth.app.data import sample_openface_csv
from facesynth.app.entry import INTERRUPTED, main

ROOT = Path(__file__).resolve().parents[2]

#: The console script's own code, with a line on stdout once the entry module is imported (so
#: the signal lands in facesynth's imports and run, not in Python's start-up before them).
CHILD = (
    "import sys; from facesynth.app.entry import main; print('entered', flush=True); "
    "raise SystemExit(main(sys.argv[1:]))"
)


@pytest.mark.parametrize("delay", [0.0, 0.1, 0.3, 0.6])
def test_ctrl_c_in_the_first_moments_of_run_is_quiet(delay: float, tmp_path: Path) -> None:
    """Measured before: a 17-60 line KeyboardInterrupt traceback up to about 0.5 s in."""
    argv = [sys.executable, "-c", CHILD, "run", "--ticks", "100", "--listen", "tcp/127.0.0.1:0"]
    argv += ["--openface-csv", str(sample_openface_csv()), "--out", str(tmp_path / "c.jsonl")]
    process = subprocess.Popen(argv, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert process.stdout is not None
    assert process.stdout.readline() == b"entered\n"
    time.sleep(delay)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode == INTERRUPTED, err.decode()
    assert b"Traceback" not in err


def test_the_entry_point_runs_the_command(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["profile", "check", "paper16"]) == 0
    assert "paper16: ok" in capsys.readouterr().out
