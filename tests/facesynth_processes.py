"""``python -m facesynth ARGS`` as real OS processes, for the tests that start services.

Each process logs to ``<folder>/<name>.log``; :meth:`Processes.stop` sends SIGTERM, then SIGKILL
after 10 s, to whatever is still running (the fixtures call it at the end of a test).
"""

from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


class Processes:
    """Starts facesynth commands as processes and reads what they printed."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.procs: list[subprocess.Popen[bytes]] = []

    def start(self, *args: str, name: str, prefix: tuple[str, ...] = ()) -> subprocess.Popen[bytes]:
        """Start ``python -m facesynth ARGS`` (after ``prefix``, e.g. ``ip netns exec NS``),
        logging to ``<name>.log``."""
        with open(self.folder / f"{name}.log", "wb") as log:
            proc = subprocess.Popen(
                [*prefix, sys.executable, "-m", "facesynth", *args],
                stdout=log,
                stderr=subprocess.STDOUT,
                env={**os.environ, "PYTHONUNBUFFERED": "1"},
            )
        self.procs.append(proc)
        return proc

    __call__ = start

    def log(self, name: str) -> str:
        """What a process printed so far."""
        return (self.folder / f"{name}.log").read_text(errors="replace")

    def wait_for_line(self, name: str, text: str, timeout: float = 30.0) -> str:
        """The first line of a process's log containing ``text`` (fails after ``timeout``)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for line in self.log(name).splitlines():
                if text in line:
                    return line
            time.sleep(0.05)
        raise AssertionError(f"{name} never printed {text!r}; it printed:\n{self.log(name)}")

    def start_simhead(self, link: str | Path) -> str:
        """``facesynth simhead`` (process ``head``) with its Maestro on the pty ``link``; its
        camera URL once it serves one."""
        self.start(
            "simhead", "--serial-link", str(link), "--http", f"127.0.0.1:{free_port()}", name="head"
        )
        line = self.wait_for_line("head", "camera:", timeout=60)
        url = re.search(r"camera: (\S+)", line)
        assert url is not None, line
        return url.group(1)

    def stop(self) -> None:
        """SIGTERM to every process still running, then SIGKILL after 10 s."""
        for proc in self.procs:
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
        for proc in self.procs:
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


@contextmanager
def simhead_device(folder: Path) -> Iterator[tuple[str, str]]:
    """``facesynth simhead`` (simhead16) running in ``folder``, its own state there: its
    Maestro's serial link and its camera's URL; stopped on the way out."""
    processes = Processes(folder)
    saved = os.environ.get("FACESYNTH_STATE")
    try:
        os.environ["FACESYNTH_STATE"] = str(folder / "facesynth-state")  # not the user's
        try:
            link = str(folder / "simhead-tty")
            camera = processes.start_simhead(link)
        finally:
            if saved is None:
                os.environ.pop("FACESYNTH_STATE", None)
            else:
                os.environ["FACESYNTH_STATE"] = saved
        yield link, camera
    finally:
        processes.stop()


def free_port() -> int:
    """A TCP port free on loopback right now (for a router that must listen on a known port)."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def run_facesynth(*args: str, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    """Run one facesynth command to its end."""
    return subprocess.run(
        [sys.executable, "-m", "facesynth", *args], capture_output=True, text=True, timeout=timeout
    )
