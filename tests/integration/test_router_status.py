"""``facesynth router`` and ``facesynth status`` as real processes."""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import time
from typing import Any


def _locator(spawn: Any, name: str, timeout: float = 15.0) -> str:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        match = re.search(r"listening on (tcp/[0-9.]+:\d+)", spawn.log(name))
        if match:
            return match.group(1)
        time.sleep(0.05)
    raise AssertionError(f"no locator in the router's output:\n{spawn.log(name)}")


def _status(locator: str, rig: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [
            sys.executable,
            "-m",
            "facesynth",
            "status",
            "--connect",
            locator,
            "--rig",
            rig,
            "--timeout",
            "1.5",
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )


def test_status_lists_live_services_with_stats(spawn: Any, rig: str) -> None:
    spawn("router", "--listen", "tcp/127.0.0.1:0", name="router")
    locator = _locator(spawn, "router")
    common = ["--connect", locator, "--rig", rig, "--stats-interval", "0.2"]
    features = spawn("features", *common, name="features")
    spawn("translator", *common, name="translator")
    deadline = time.monotonic() + 30
    while True:
        result = _status(locator, rig)
        rows = [line.split() for line in result.stdout.splitlines()[1:]]
        services = {row[1] for row in rows if row and row[0] == rig}
        if services == {"features", "translator"} or time.monotonic() > deadline:
            break
    assert services == {"features", "translator"}, result.stdout + result.stderr
    assert result.returncode == 0
    assert all(row[3] != "(no" for row in rows), "every live service reports stats"

    features.send_signal(signal.SIGTERM)
    assert features.wait(timeout=15) == 0
    deadline = time.monotonic() + 15
    while time.monotonic() < deadline:
        rows = [line.split() for line in _status(locator, rig).stdout.splitlines()[1:]]
        if {row[1] for row in rows if row and row[0] == rig} == {"translator"}:
            break
    else:
        raise AssertionError("a stopped service is still listed")


def test_status_without_services_says_so(spawn: Any, rig: str) -> None:
    spawn("router", "--listen", "tcp/127.0.0.1:0", name="router")
    result = _status(_locator(spawn, "router"), rig)
    assert result.returncode == 1
    assert "(no live services)" in result.stdout


def test_killed_service_disappears(spawn: Any, rig: str) -> None:
    spawn("router", "--listen", "tcp/127.0.0.1:0", name="router")
    locator = _locator(spawn, "router")
    victim = spawn("features", "--connect", locator, "--rig", rig, name="features")
    deadline = time.monotonic() + 30
    while "features" not in _status(locator, rig).stdout:
        assert time.monotonic() < deadline, spawn.log("features")
    victim.kill()
    victim.wait()
    deadline = time.monotonic() + 20
    while "features" in _status(locator, rig).stdout:
        assert time.monotonic() < deadline, "a killed service's token should vanish"


def test_stages_behind_a_stopped_sensor_show_no_rate(spawn: Any, rig: str) -> None:
    """The sensor sends 2 s of video and exits; points and features stay alive, idle."""
    from facesynth.app.data import sample_openface_csv

    spawn("router", "--listen", "tcp/127.0.0.1:0", name="router")
    locator = _locator(spawn, "router")
    common = ["--connect", locator, "--rig", rig, "--stats-interval", "0.2"]
    spawn("points", *common, "--openface-csv", str(sample_openface_csv()), name="points")
    spawn("features", *common, name="features")
    sensor = spawn(
        "sensor", *common, "--max-frames", "48", "--wait-for", "points,features", name="sensor"
    )
    assert sensor.wait(timeout=60) == 0, spawn.log("sensor")
    time.sleep(2.0)  # longer than the idle threshold (1 s)
    result = _status(locator, rig)
    header, *lines = result.stdout.splitlines()
    rows = {line.split()[1]: line for line in lines if line.split()[0] == rig}
    assert set(rows) == {"points", "features"}, result.stdout + result.stderr
    rate = header.index("rate Hz")
    for service, line in rows.items():
        assert line[rate : rate + 8].strip() == "0.0", (service, result.stdout)
        assert re.search(r"  idle \d+ s$", line), (service, result.stdout)
        assert int(line.split()[7]) > 0, (service, result.stdout)  # it did publish ("sent")
