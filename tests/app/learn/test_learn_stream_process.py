"""``facesynth learn --plan stream`` end to end, as processes: the simulated head (Maestro over
a pty, its camera an MJPEG URL) swept pose by pose, then kept moving while every camera frame
is recorded with the commands in force, and a profile fitted on both."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from facesynth_processes import run_facesynth

from facesynth.app.learn.plan import Plan, PlanOptions
from facesynth.app.learn.session import read_session
from facesynth.runtime.profiles import load_profile

pytestmark = pytest.mark.slow


@pytest.mark.timeout(360)  # about 2 minutes: the sweeps (35-60 s), the stream, the fit
def test_learn_streams_the_simulated_head_after_its_sweeps_and_fits_the_frames(
    simhead: tuple[str, str], tmp_path: Path
) -> None:
    link, camera = simhead
    session = tmp_path / "s.mcap"
    learned = tmp_path / "streamed.learned"
    profile = load_profile("paper16")
    learn = ["learn", "--profile", "paper16", "--driver", "maestro", "--port", link]
    learn += ["--camera", camera, "--out", str(session), "--out-profile", str(learned)]
    learn += ["--plan", "stream", "--sweep-steps", "1", "--minutes", "1.2"]
    done = run_facesynth(*learn, "--log-level", "WARNING", timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    summary = json.loads(next(line for line in done.stdout.splitlines() if '"session"' in line))
    sweeps = Plan(len(profile.servos), PlanOptions(0, 1)).sweep_poses
    assert summary["taken"] >= sweeps, (summary, done.stderr[-2000:])
    assert summary["streamed_frames"] > 150, (summary, done.stderr[-2000:])  # 5 s of frames
    read = read_session(session)
    poses = [s for s in read.samples if s.kind != "stream"]
    # the sweeps, then only the stream's settled neutrals (one every 20 s)
    assert [s.seq for s in poses] == list(range(len(poses))) and read.next_pose == len(poses)
    assert {s.kind for s in poses[sweeps:]} <= {"neutral"}
    assert read.plan == "stream"
    stream = [s for s in read.samples if s.kind == "stream"]
    assert len(stream) == summary["streamed_frames"]
    assert all(s.seq >= sweeps and not s.settled and s.features for s in stream)
    # frames in time order, after the last sweep, the commands within the profile and moving
    times = [s.t_capture_ns for s in stream]
    assert times == sorted(times)
    assert times[0] > max(s.t_capture_ns for s in poses[:sweeps]) - 1e9
    for spec in profile.servos:
        values = np.array([s.commanded[spec.name] for s in stream])
        assert spec.min_us <= values.min() and values.max() <= spec.max_us
        assert np.ptp(values) > 0.2 * (spec.max_us - spec.min_us), spec.name
    # the fit takes the frames (far more samples than poses) and holds out stretches of them
    fitted = load_profile(str(learned)).learned
    assert fitted is not None and fitted.report is not None
    assert fitted.report.samples > sweeps + 100, done.stdout[-2000:]
    assert "fitted in" in done.stdout
