"""A plan rehearsed on the robot (facesynth/app/plan/rehearsal.py, ``plan_performance``'s look,
``facesynth plan --driver … --camera …``): poses given as pulses and back, the frames a round
poses, the round the robot showed best written, a rehearsal stopped, and the command end to end
on a simulated head behind its Maestro and its camera URL, Ctrl-C included."""

from __future__ import annotations

import json
import re
import signal
import time
from pathlib import Path

import numpy as np
import pytest
from facesynth_processes import Processes, run_facesynth, simhead_device
from simhead16_laugh import HEAD, laughing, learned_simhead16

from facesynth.app.bench.likeness_budget import Looker
from facesynth.app.cli import main
from facesynth.app.data import sample_video
from facesynth.app.learn.plan import to_pulses
from facesynth.app.learn.session import read_session
from facesynth.app.plan.performance import plan_performance, pulses
from facesynth.app.plan.rehearsal import ShownPoses, looked_rows, normalized, round_path
from facesynth.app.recording.reader import Recording
from facesynth.runtime.profiles import load_profile, save_learned_profile


def test_poses_given_as_pulses_are_to_pulses_undone() -> None:
    profile = load_profile("head16_hardware")
    for u in np.random.default_rng(0).uniform(-1, 1, (20, len(profile.servos))):
        assert normalized(profile, to_pulses(profile, u)) == pytest.approx(u)
    assert normalized(profile, {}) == (0.0,) * len(profile.servos)  # not named: neutral
    spec = profile.servos[0]
    assert normalized(profile, {spec.name: spec.max_us + 500})[0] == 1.0  # clamped first
    assert normalized(profile, {spec.name: spec.min_us - 500})[0] == -1.0


def test_a_round_shows_the_given_poses_in_order() -> None:
    profile = load_profile("head16_hardware")
    wanted = [to_pulses(profile, np.full(16, v)) for v in (0.5, -0.25)]
    poses = ShownPoses(profile, wanted)
    assert [to_pulses(profile, poses.pose(i).u) for i in range(2)] == wanted
    assert poses.pose(5) == poses.pose(1) and poses.pose(0).kind == "rehearsal"
    with pytest.raises(ValueError, match="one pose or more"):
        ShownPoses(profile, [])


def test_a_round_poses_every_kth_frame_and_the_last() -> None:
    assert looked_rows(10, 1) == list(range(10))
    assert looked_rows(10, 3) == [0, 3, 6, 9]
    assert looked_rows(10, 4) == [0, 4, 8, 9]
    with pytest.raises(ValueError, match="every 0"):
        looked_rows(10, 0)
    assert round_path("/a/p.mcap", 2) == Path("/a/p.round2.mcap")


def test_the_plan_written_is_the_round_the_robot_showed_best() -> None:
    profile, features = learned_simhead16(), laughing().features[:60]
    looker = Looker(profile, HEAD)
    shown: list[np.ndarray] = []

    def look(commands: np.ndarray) -> np.ndarray:
        shown.append(commands.copy())
        return np.array([looker.face(u) for u in commands])

    plan = plan_performance(profile, features, look=look, rounds=1)
    assert len(shown) == len(plan.robot_rho) == 2 and not plan.stopped
    assert all(-1 <= rho <= 1 for rho in plan.robot_rho)
    assert plan.kept_round in (0, 1)
    planned = [i for i, f in enumerate(features) if f.face and f.neutral_ready]
    written = [plan.positions[i] for i in planned]
    assert written == pulses(profile, shown[plan.kept_round])
    # round 0 is the plan through the self-model, as without a robot
    alone = plan_performance(profile, features)
    assert [alone.positions[i] for i in planned] == pulses(profile, shown[0])


def test_a_rehearsal_stopped_before_a_round_keeps_the_plan_through_the_self_model() -> None:
    profile, features = learned_simhead16(), laughing().features[:60]
    plan = plan_performance(profile, features, look=lambda commands: None)
    assert plan.stopped and plan.robot_rho == [] and plan.kept_round is None
    assert plan.positions == plan_performance(profile, features).positions


def test_a_rounds_file_is_never_written_over(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    learned = save_learned_profile(learned_simhead16(), tmp_path / "s16.learned")
    out = tmp_path / "p.mcap"
    round_path(out, 1).write_bytes(b"kept")
    argv = ["plan", str(sample_video()), "--profile", str(learned), "--out", str(out)]
    robot = ["--driver", "maestro", "--port", str(tmp_path / "none"), "--camera", "0"]
    assert main([*argv, *robot, "--rounds", "2"]) == 2
    assert "p.round1.mcap exists (a rehearsal's round is never written over)" in (
        capsys.readouterr().err
    )
    assert round_path(out, 1).read_bytes() == b"kept" and not out.exists()


def _summary(stdout: str) -> dict[str, object]:
    summary: dict[str, object] = json.loads(stdout.strip().splitlines()[-1])
    return summary


def test_facesynth_plan_rehearses_on_the_head_and_a_ctrl_c_keeps_what_was_shown(
    tmp_path: Path,
) -> None:
    learned = save_learned_profile(learned_simhead16(), tmp_path / "s16.learned")
    with simhead_device(tmp_path) as (link, camera):
        robot = ["--driver", "maestro", "--port", link, "--camera", camera]
        out = tmp_path / "p.mcap"
        argv = ["plan", str(sample_video()), "--profile", str(learned), "--frames", "40"]
        done = run_facesynth(
            *argv, "--out", str(out), *robot, "--rounds", "1", "--look-every", "5", timeout=240
        )
        assert done.returncode == 0, done.stderr[-3000:]
        summary = _summary(done.stdout)
        assert len(summary["robot_rho_rounds"]) == 2, summary  # type: ignore[arg-type]
        assert summary["kept_round"] in (0, 1) and summary["rehearsal_stopped"] is False
        planned = int(summary["planned_frames"])  # type: ignore[call-overload]
        for k in (0, 1):
            session = read_session(round_path(out, k))
            assert [s.seq for s in session.samples] == list(range(len(looked_rows(planned, 5))))
            assert {s.kind for s in session.samples} == {"rehearsal"}
        with Recording(out) as recording:
            assert recording.stages() == ["servo_commands"]

        # Ctrl-C in the first round: the head back at neutral, the round's file complete,
        # the plan through the self-model written
        stopped = tmp_path / "q.mcap"
        processes = Processes(tmp_path)
        processes.start(*argv, "--out", str(stopped), *robot, name="plan")
        proc = processes.procs[-1]
        deadline = time.monotonic() + 120
        while "babbling [#" not in processes.log("plan") and time.monotonic() < deadline:
            time.sleep(0.1)
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=60) == 130, processes.log("plan")[-3000:]
        status = run_facesynth(
            "control", "status", "--driver", "maestro", "--port", link, "--profile", str(learned)
        )
        assert status.returncode == 0, status.stderr
    neutral = {spec.name: spec.neutral_us for spec in learned_simhead16().servos}
    reported = re.findall(r"^\s+(\w+)\s+([\d.]+)\s*$", status.stdout, re.MULTILINE)
    assert reported and all(abs(float(us) - neutral[name]) <= 1 for name, us in reported)
    log = processes.log("plan")
    assert "Traceback" not in log and "rehearsal stopped in round 0" in log
    summary = next(json.loads(line) for line in log.splitlines() if line.startswith('{"out"'))
    assert summary["rehearsal_stopped"] is True and summary["kept_round"] is None
    assert summary["robot_rho_rounds"] == []
    assert read_session(round_path(stopped, 0)).samples  # what was shown is kept
    assert not round_path(stopped, 1).exists()
    with Recording(stopped) as recording:
        assert recording.stages() == ["servo_commands"]
