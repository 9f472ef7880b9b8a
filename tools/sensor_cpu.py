"""The sensor's CPU per frame on an MJPEG camera URL: passthrough against decoding (issue 19).

    python tools/sensor_cpu.py [--frames 600] [--rounds 2]

Starts a Zenoh router and ``facesynth simhead --http`` (its camera: 320x320 JPEGs at 30 fps),
then runs ``facesynth sensor --camera URL`` as its own process, with the camera's JPEGs passed
through (the default) and with ``--no-passthrough`` (decoded by FFmpeg, JPEG-encoded again),
interleaved, ``--rounds`` times each, with a subscriber on its ``…/input`` key in this
process (so every frame crosses the router, as in a chain; it counts the frames). Each run's
CPU time is the child's user + system time (every thread, from ``wait4``); the start-up is
taken out by running each variant twice, for a few frames and for ``--frames`` more, and
dividing the difference by the frame difference.
Prints each run's figure and the mean per variant, with the load average.
"""

from __future__ import annotations

import argparse
import os
import socket
import statistics
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

from facesynth.app.bench.processes import ProcessGroup
from facesynth.runtime import keys
from facesynth.runtime.bus.zenoh_bus import ZenohOptions, open_session

RIG = "sensorcpu"

#: Frames of the short run whose CPU is taken off (the start-up and the first frames).
WARMUP_FRAMES = 30


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def wait_for_camera(url: str, timeout: float = 30.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            with urllib.request.urlopen(url.replace("camera.mjpg", "camera.jpg"), timeout=2):
                return
        except OSError:
            time.sleep(0.2)
    raise SystemExit(f"the simulated head's camera {url} did not answer")


def sensor_cpu_s(group: ProcessGroup, url: str, frames: int, passthrough: bool, name: str) -> float:
    """CPU seconds of one ``facesynth sensor`` process sending ``frames`` frames."""
    args = ["sensor", "--camera", url, "--max-frames", str(frames), "--wait-timeout", "0"]
    args += ["--connect", group.locator, "--mode", "client", "--rig", RIG]
    args.append("--passthrough" if passthrough else "--no-passthrough")
    proc = group.start(name, *args)
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        log = group.log(name).read_text(errors="replace")
        raise SystemExit(f"{name} failed ({proc.returncode}):\n{log[-2000:]}")
    return usage.ru_utime + usage.ru_stime


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=600, help="frames counted per run")
    parser.add_argument("--rounds", type=int, default=2, help="runs per variant, interleaved")
    options = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="sensor-cpu-") as folder:
        group = ProcessGroup(Path(folder))
        try:
            group.start_router()
            port = free_port()
            link = str(Path(folder) / "simhead-tty")
            group.start("simhead", "simhead", "--http", f"127.0.0.1:{port}", "--serial-link", link)
            url = f"http://127.0.0.1:{port}/camera.mjpg"
            wait_for_camera(url)
            received = [0]
            session = open_session(ZenohOptions(mode="client", connect=[group.locator]))
            session.declare_subscriber(
                keys.stage_key(RIG, "input"), lambda _: received.__setitem__(0, received[0] + 1)
            )
            figures: dict[str, list[float]] = {"passthrough": [], "decode": []}
            for round_ in range(options.rounds):
                for variant in figures:
                    passthrough = variant == "passthrough"
                    name = f"{variant}-{round_}"
                    short = sensor_cpu_s(group, url, WARMUP_FRAMES, passthrough, name + "-short")
                    total = WARMUP_FRAMES + options.frames
                    long = sensor_cpu_s(group, url, total, passthrough, name + "-long")
                    per_frame_ms = (long - short) / options.frames * 1e3
                    figures[variant].append(per_frame_ms)
                    print(
                        f"{variant:<12} round {round_ + 1}: {per_frame_ms:.2f} ms per frame "
                        f"({received[0]}/{WARMUP_FRAMES + total} frames received)"
                    )
                    received[0] = 0
            session.close()
        finally:
            group.close()
    load = ", ".join(f"{x:.2f}" for x in os.getloadavg())
    print(f"\nsensor CPU per frame on {url} ({options.frames} frames a run, load {load}):")
    for variant, values in figures.items():
        runs = ", ".join(f"{v:.2f}" for v in values)
        print(f"  {variant:<12} mean {statistics.mean(values):.2f} ms (runs: {runs})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
