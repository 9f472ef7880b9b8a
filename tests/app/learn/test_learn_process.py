"""``facesynth learn`` end to end, as processes: the simulated head (Maestro over a pty, its
camera as an MJPEG URL) babbled through the maestro driver, a run to its budget, then a resumed
run stopped with Ctrl-C: the servos back at neutral, every sample kept."""

from __future__ import annotations

import json
import re
import signal
import time
from pathlib import Path

import pytest
from facesynth_processes import Processes, run_facesynth

from facesynth.app.learn.session import read_session
from facesynth.runtime.profiles import load_profile

pytestmark = pytest.mark.slow

#: The first run's budget: the neutral pose and the first servo's sweeps (and one more).
FIRST = 8


def _wait_for_poses(processes: Processes, name: str, more_than: int, timeout: float) -> None:
    """Until a progress line of ``name`` counts more than ``more_than`` poses taken."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        counts = re.findall(r"babbling \[[#.]*\] (\d+)/", processes.log(name))
        if counts and int(counts[-1]) > more_than:
            return
        time.sleep(0.05)
    raise AssertionError(f"{name} took no more than {more_than} poses:\n{processes.log(name)}")


def _positions(link: str) -> dict[str, float]:
    """Where the head's Maestro says each servo is (``control status``)."""
    status = run_facesynth(
        "control", "status", "--driver", "maestro", "--port", link, "--profile", "paper16"
    )
    assert status.returncode == 0, status.stderr
    found = re.findall(r"^\s+(\w+)\s+([\d.]+)\s*$", status.stdout, re.MULTILINE)
    return {name: float(value) for name, value in found}


def test_learn_babbles_the_simulated_head_resumes_and_stops_at_neutral(
    simhead: tuple[str, str], processes: Processes, tmp_path: Path
) -> None:
    link, camera = simhead
    session = tmp_path / "s.mcap"
    learn = ["learn", "--profile", "paper16", "--driver", "maestro", "--port", link]
    learn += ["--camera", camera, "--out", str(session), "--no-fit", "--log-level", "WARNING"]
    first = run_facesynth(*learn, "--poses", str(FIRST), timeout=120)
    assert first.returncode == 0, first.stderr[-3000:]
    summary = json.loads(first.stdout.strip().splitlines()[-1])
    assert summary["poses"] == summary["taken"] == FIRST, summary
    samples = read_session(session).samples
    assert [s.seq for s in samples] == list(range(FIRST))
    neutral = samples[0]
    assert neutral.kind == "neutral" and neutral.features
    # the head moves when a servo sweeps: some face feature leaves its neutral value (the head
    # pose's own jitter, 0.03-0.07 with every command neutral, is not a move of the face)
    moved = max(
        abs(s.features[name] - neutral.features[name])
        for s in samples
        if s.kind == "sweep"
        for name in s.features.keys() & neutral.features.keys()
        if not name.startswith("head_")
    )
    assert moved > 0.2, moved
    assert "babbling [" in first.stderr and "left" in first.stderr

    # a second run resumes the plan; Ctrl-C sends the head back to neutral and keeps the file
    processes(*learn, "--poses", "400", name="again")
    _wait_for_poses(processes, "again", FIRST + 1, timeout=60)  # two past the first run's
    proc = processes.procs[-1]
    proc.send_signal(signal.SIGINT)
    assert proc.wait(timeout=30) == 130
    log = processes.log("again")
    assert "Traceback" not in log
    samples = read_session(session).samples
    assert len(samples) > FIRST
    assert [s.seq for s in samples] == list(range(len(samples)))
    positions = _positions(link)
    expected = load_profile("paper16").neutral_positions()
    assert positions.keys() == expected.keys()
    for name, value in expected.items():
        assert positions[name] == pytest.approx(value, abs=1.0)


def test_learn_with_the_adaptive_plan_babbles_the_simulated_head_and_resumes_it(
    simhead: tuple[str, str], tmp_path: Path
) -> None:
    link, camera = simhead
    session = tmp_path / "s.mcap"
    learn = ["learn", "--profile", "paper16", "--driver", "maestro", "--port", link]
    learn += ["--camera", camera, "--out", str(session), "--no-fit", "--neutral-every", "5"]
    first = run_facesynth(*learn, "--plan", "adaptive", "--poses", "6", timeout=120)
    assert first.returncode == 0, first.stderr[-3000:]
    assert json.loads(first.stdout.strip().splitlines()[-1])["taken"] == 6
    read = read_session(session)
    assert read.plan == "adaptive"
    # the adaptive plan's finer sweeps: a sixth of the travel first
    assert [s.kind for s in read.samples] == ["neutral", *["sweep"] * 4, "neutral"]
    servo = load_profile("paper16").servos[0]
    step = (servo.max_us - servo.neutral_us) / 6
    assert read.samples[1].commanded[servo.name] == pytest.approx(servo.neutral_us + step, abs=1)
    # a resume keeps the session's plan and tells it the poses taken so far first
    again = run_facesynth(*learn, "--poses", "8", "--log-level", "INFO", timeout=120)
    assert again.returncode == 0, again.stderr[-3000:]
    assert f"the adaptive plan was told the 6 poses of {session}" in again.stderr
    samples = read_session(session).samples
    assert [s.seq for s in samples] == list(range(8))
    assert all(s.features for s in samples)
