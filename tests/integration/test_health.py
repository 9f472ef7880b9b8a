"""``facesynth health``: the container health check, against a real router and service."""

from __future__ import annotations

import re
import subprocess
import sys
import time
from typing import Any


def _health(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "facesynth", "health", "--timeout", "2", *args],
        capture_output=True,
        text=True,
        timeout=60,
    )


def test_healthy_only_while_this_hosts_service_is_live(spawn: Any, rig: str) -> None:
    spawn("router", "--listen", "tcp/127.0.0.1:0", name="router")
    deadline = time.monotonic() + 15
    while not (match := re.search(r"listening on (tcp/[0-9.]+:\d+)", spawn.log("router"))):
        assert time.monotonic() < deadline, spawn.log("router")
        time.sleep(0.05)
    locator = match.group(1)
    common = ["--connect", locator, "--rig", rig]

    before = _health(*common)
    assert before.returncode == 1 and "unhealthy: no live service" in before.stdout
    router = _health("--router", "--connect", locator)
    assert router.returncode == 0 and "accepts sessions" in router.stdout

    features = spawn("features", *common, name="features")
    deadline = time.monotonic() + 30
    while (result := _health(*common)).returncode != 0:
        assert time.monotonic() < deadline, result.stdout + spawn.log("features")
    assert "/health/features/" in result.stdout
    assert _health(*common, "--host", "another-host").returncode == 1

    features.kill()
    features.wait()
    deadline = time.monotonic() + 20
    while _health(*common).returncode != 1:
        assert time.monotonic() < deadline, "a dead service must make the check fail"


def test_unhealthy_without_a_router() -> None:
    result = _health("--mode", "client", "--connect", "tcp/127.0.0.1:9")
    assert result.returncode == 1
    assert result.stdout.startswith("unhealthy: cannot open a Zenoh client session")
    assert "Traceback" not in result.stderr
