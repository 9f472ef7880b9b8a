"""A soak (``python -m tools.soak``) started for an hour and interrupted mid-fault: the steps
the fault group's SIGINT test and the netns group's SIGTERM test share."""

from __future__ import annotations

import os
import signal
import subprocess
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Interrupted:
    """How an interrupted soak ended: its exit code, the seconds from the signal to its exit,
    what it printed, and its process-group leader's pid."""

    code: int
    took_s: float
    printed: str
    pid: int


def interrupt_soak(
    command: Sequence[str],
    log: Path,
    mid_fault: Callable[[int], bool],
    signum: int,
    *,
    deadline_s: float,
) -> Interrupted:
    """Start ``command`` (a soak, in a session of its own, printing into ``log``), wait until it
    streams and then until ``mid_fault(pid)`` says its fault is under way, send ``signum`` and
    wait (30 s at most) for it to end; a soak still running then is killed with its group."""
    with open(log, "wb") as printed:
        soak = subprocess.Popen(
            command, cwd=ROOT, stdout=printed, stderr=subprocess.STDOUT, start_new_session=True
        )
    try:
        deadline = time.monotonic() + deadline_s
        while "soak: the chain streams" not in log.read_text() and soak.poll() is None:
            assert time.monotonic() < deadline, log.read_text()[-3000:]
            time.sleep(0.1)
        while not mid_fault(soak.pid):
            assert time.monotonic() < deadline and soak.poll() is None, log.read_text()[-3000:]
            time.sleep(0.05)
        signalled = time.monotonic()
        soak.send_signal(signum)
        code = soak.wait(timeout=30)
        took = time.monotonic() - signalled
    finally:
        if soak.poll() is None:
            os.killpg(soak.pid, signal.SIGKILL)
            soak.wait()
    text = log.read_text()
    print(text[-3000:])
    return Interrupted(code, took, text, soak.pid)
