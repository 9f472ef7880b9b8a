"""Ctrl-C early in `facesynth run` (issue 20): exit 130, no traceback, even while importing."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from facesynth.app.data import sample_openface_csv
from facesynth.app.entry import INTERRUPTED, THREADS_GRACE_S, held_interrupts, main

ROOT = Path(__file__).resolve().parents[2]

#: The console script's own code (``run``, which ends by ``leave``), with a line on stdout once
#: the entry module is imported (so the signal lands in facesynth's imports and run, not in
#: Python's start-up before them).
CHILD = "from facesynth.app.entry import run; print('entered', flush=True); run()"


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


def test_a_ctrl_c_while_importing_is_held_until_the_imports_are_done() -> None:
    """Raised inside an import, it crashed msgspec building a decoder (6 segmentation faults in
    300 starts interrupted 0.08-0.25 s in, under load) or was lost in an import lock's callback."""
    with held_interrupts() as held:
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.01)  # the handler runs between bytecodes: no KeyboardInterrupt here
    assert held == [signal.SIGINT]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_second_ctrl_c_while_importing_interrupts_at_once() -> None:
    with pytest.raises(KeyboardInterrupt), held_interrupts() as held:
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.01)
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(1)
    assert held == [signal.SIGINT, signal.SIGINT]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_the_entry_point_runs_the_command(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["profile", "check", "paper16"]) == 0
    assert "paper16: ok" in capsys.readouterr().out


#: A thread waits inside Zenoh (a subscriber's ``recv``, the GIL released) when the command
#: ends; a sample then arrives while the interpreter is finalizing (published from an object's
#: ``__del__``, which finalization runs), so the thread returns into a finalizing interpreter.
ZENOH_THREAD_AT_EXIT = """
import sys, threading, time, zenoh
from facesynth.app.entry import leave
config = zenoh.Config()
config.insert_json5("scouting/multicast/enabled", "false")
config.insert_json5("mode", '"peer"')
session = zenoh.open(config)
subscriber = session.declare_subscriber("facesynth/test/exit")
threading.Thread(target=subscriber.recv, daemon=True).start()
class LateSample:
    def __del__(self):
        session.put("facesynth/test/exit", b"late")
        time.sleep(0.5)
late = LateSample()
time.sleep(0.1)
print("done", flush=True)
if sys.argv[1] == "leave":
    leave(0)
"""


def _end_with(how: str) -> subprocess.CompletedProcess[str]:
    argv = [sys.executable, "-c", ZENOH_THREAD_AT_EXIT, how]
    return subprocess.run(argv, cwd=ROOT, capture_output=True, text=True, timeout=60)


def test_a_thread_inside_zenoh_at_exit_aborts_a_finalizing_interpreter() -> None:
    """The hazard :func:`leave` avoids, shown as it happens without it (CPython 3.11-3.13)."""
    ended = _end_with("finalize")
    assert ended.stdout == "done\n"
    assert ended.returncode == -signal.SIGABRT
    assert "FATAL: exception not rethrown" in ended.stderr


def test_leaving_without_finalization_ends_cleanly_with_that_thread() -> None:
    ended = _end_with("leave")
    assert (ended.returncode, ended.stdout) == (0, "done\n")
    assert "FATAL" not in ended.stderr


@pytest.mark.parametrize(
    ("argv", "status", "out", "err"),
    [
        (["profile", "check", "paper16"], 0, "paper16: ok", ""),
        (["no-such-command"], 2, "", "invalid choice: 'no-such-command'"),
        (["--help"], 0, "usage: facesynth", ""),
    ],
)
def test_the_module_entry_keeps_status_and_every_line_written(
    argv: list[str], status: int, out: str, err: str
) -> None:
    """``python -m facesynth`` ends by :func:`leave`: piped output is flushed, statuses kept."""
    ended = subprocess.run(
        [sys.executable, "-m", "facesynth", *argv],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert ended.returncode == status, ended.stderr
    assert out in ended.stdout
    assert err in ended.stderr


def test_an_executor_left_open_does_not_hold_the_exit() -> None:
    """Its idle workers are not daemons: threading's exit hooks tell them to end, as Python's
    own exit does, instead of :func:`leave` waiting out its grace for them."""
    child = (
        "import concurrent.futures, time; from facesynth.app.entry import leave; "
        "concurrent.futures.ThreadPoolExecutor(2).submit(time.sleep, 0.01).result(); leave(3)"
    )
    started = time.monotonic()
    ended = subprocess.run([sys.executable, "-c", child], cwd=ROOT, timeout=60)
    assert ended.returncode == 3
    assert time.monotonic() - started < THREADS_GRACE_S
