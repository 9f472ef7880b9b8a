"""A recorded performance planned for a learned robot (facesynth/app/plan/performance.py and
``facesynth plan``): every frame's pulses within the limits, the plan's likeness above T's,
the lead, the recording it writes, and what it refuses."""

from __future__ import annotations

import json
from pathlib import Path

import msgspec
import pytest

from facesynth.app.cli import main
from facesynth.app.data import sample_video
from facesynth.app.engine.performer import TrackedVideo, track_video
from facesynth.app.learn.fit import FitOptions, fit_learned_profile
from facesynth.app.learn.inprocess import babble_simhead, hardware_for
from facesynth.app.plan.performance import (
    SENDER,
    PlanError,
    PlannedPerformance,
    plan_performance,
    write_plan,
)
from facesynth.app.recording.reader import Recording
from facesynth.app.simhead import load_head
from facesynth.runtime.profiles import Profile, load_profile, save_learned_profile
from facesynth.runtime.profiles.learned import shown_inputs
from facesynth.schemas.messages import ServoCommands

FRAMES = 60


@pytest.fixture(scope="module")
def robot() -> Profile:
    """A profile learned on seed:2 from 60 poses (a partial fit is enough here)."""
    hardware = hardware_for(load_head("seed:2"))
    babbled = babble_simhead(hardware, 60, head="seed:2")
    return fit_learned_profile(babbled, hardware, FitOptions(partial=True))


@pytest.fixture(scope="module")
def performer() -> TrackedVideo:
    return track_video(str(sample_video()), frames=FRAMES)


@pytest.fixture(scope="module")
def plan(robot: Profile, performer: TrackedVideo) -> PlannedPerformance:
    return plan_performance(robot, performer.features)


def test_every_frame_has_every_servo_within_its_limits(
    robot: Profile, plan: PlannedPerformance
) -> None:
    assert len(plan.positions) == FRAMES
    for positions in plan.positions:
        assert set(positions) == {spec.name for spec in robot.servos}
        for spec in robot.servos:
            assert spec.min_us <= positions[spec.name] <= spec.max_us


def test_frames_before_her_neutral_hold_the_robots_neutral(
    robot: Profile, performer: TrackedVideo, plan: PlannedPerformance
) -> None:
    neutral = {spec.name: spec.neutral_us for spec in robot.servos}
    waiting = [i for i, f in enumerate(performer.features) if not f.neutral_ready]
    assert waiting  # F's first second is its neutral
    for index in waiting:
        assert plan.positions[index] == neutral
    assert plan.planned_frames == FRAMES - len(waiting)
    moved = [i for i in range(FRAMES) if plan.positions[i] != neutral]
    assert moved and min(moved) > max(waiting)


def test_the_plan_follows_her_better_than_t_through_the_self_model(
    robot: Profile, plan: PlannedPerformance
) -> None:
    assert robot.learned is not None
    assert plan.rho_plan > plan.rho_t + 0.05
    assert plan.followed and set(plan.followed) <= set(shown_inputs(robot.learned))


def test_the_commands_are_the_plans_frames_from_one_sender(
    performer: TrackedVideo, plan: PlannedPerformance
) -> None:
    commands = plan.commands()
    assert [c.t_media_ns for c in commands] == [f.t_media_ns for f in performer.features]
    assert [c.sender_seq for c in commands] == list(range(1, FRAMES + 1))
    assert {c.sender for c in commands} == {SENDER}
    assert [c.positions for c in commands] == plan.positions
    assert all(c.sent_ns == 0 for c in commands)  # not aged: a plan is played later


def test_a_lead_sends_each_frames_commands_early(
    robot: Profile, performer: TrackedVideo, plan: PlannedPerformance
) -> None:
    led = plan_performance(robot, performer.features, lead_frames=3)
    assert led.positions[:-3] == plan.positions[3:]
    assert led.positions[-3:] == [plan.positions[-1]] * 3
    assert led.t_media_ns == plan.t_media_ns


def test_the_written_plan_reads_back_as_its_commands(
    plan: PlannedPerformance, tmp_path: Path
) -> None:
    out = tmp_path / "plan.mcap"
    assert write_plan(plan, out, rig="lab", source="her.mp4") == FRAMES
    with Recording(out) as recording:
        assert recording.metadata["source"] == "plan:her.mp4"
        keys = recording.bus_keys()
        read = [message for _, message, _ in recording.messages(keys)]
    assert keys == ["facesynth/lab/servo_commands"]
    assert read == plan.commands()
    assert all(isinstance(m, ServoCommands) for m in read)


def test_what_cannot_be_planned_is_refused(robot: Profile, performer: TrackedVideo) -> None:
    with pytest.raises(PlanError, match="profile head16 is not learned"):
        plan_performance(load_profile("head16"), performer.features)
    assert robot.learned is not None
    blind = msgspec.structs.replace(
        robot, learned=msgspec.structs.replace(robot.learned, forward=None, plan_steps=0)
    )
    with pytest.raises(PlanError, match="no poly_ridge self-model"):
        plan_performance(blind, performer.features)
    with pytest.raises(PlanError, match="0 frames with her face and a neutral"):
        plan_performance(robot, performer.features[:10])  # within F's neutral second
    with pytest.raises(PlanError, match="0 frames or more"):
        plan_performance(robot, performer.features, lead_frames=-1)
    with pytest.raises(PlanError, match="1 round or more"):
        plan_performance(robot, performer.features, look=lambda u: None, rounds=0)


def test_facesynth_plan_writes_a_plan_replay_reads(
    robot: Profile, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "robot.learned"
    save_learned_profile(robot, path)
    out = tmp_path / "plans" / "laugh.mcap"  # the file's own folder is made
    argv = ["plan", str(sample_video()), "--profile", str(path), "--out", str(out)]
    assert main([*argv, "--frames", "40", "--lead", "0.1"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["frames"] == 40 and summary["out"] == str(out)
    assert summary["self_model_rho_plan"] > summary["self_model_rho_t"]
    with Recording(out) as recording:
        assert recording.stages() == ["servo_commands"]
    assert main([*argv, "--frames", "40"]) == 2  # never written over
    assert "exists (a plan is never written over)" in capsys.readouterr().err
    # replay plays it to C (here the record driver), which clamps and limits it as T's
    played = tmp_path / "played.jsonl"
    replay = ["replay", str(out), "--from", "servo_commands", "--graph", "--speed", "4"]
    control = ["--profile", str(path), "--driver", "record", "--out", str(played)]
    assert main([*replay, *control, "--log-level", "WARNING"]) == 0
    assert json.loads(capsys.readouterr().out.splitlines()[-1])["commands"] == 40
    lines = [json.loads(line) for line in played.read_text().splitlines()[1:]]
    assert sorted({line["frame"] for line in lines if line["frame"] is not None}) == list(range(40))
    for line in lines:
        for spec in robot.servos:
            assert spec.min_us <= line["servos"][spec.name] <= spec.max_us


def test_a_plan_for_one_robot_of_a_rig_is_on_its_key_and_replays_to_it(
    robot: Profile, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "robot.learned"
    save_learned_profile(robot, path)
    out = tmp_path / "a.mcap"
    argv = ["plan", str(sample_video()), "--profile", str(path), "--out", str(out)]
    assert main([*argv, "--frames", "40", "--rig", "lab", "--robot", "a"]) == 0
    assert json.loads(capsys.readouterr().out)["frames"] == 40
    with Recording(out) as recording:
        assert recording.bus_keys() == ["facesynth/lab/servo_commands/a"]
        assert recording.stages() == ["servo_commands"] and recording.metadata["robot"] == "a"
        read = [message for _, message, _ in recording.messages(recording.bus_keys())]
    assert len(read) == 40 and all(isinstance(m, ServoCommands) for m in read)
    # replay keeps the robot on the key: robot a's C (here the record driver) takes it
    played = tmp_path / "played.jsonl"
    replay = ["replay", str(out), "--from", "servo_commands", "--graph", "--speed", "4"]
    control = ["--robot", "a", "--profile", str(path), "--driver", "record", "--out", str(played)]
    assert main([*replay, *control, "--log-level", "WARNING"]) == 0
    assert json.loads(capsys.readouterr().out.splitlines()[-1])["commands"] == 40
    lines = [json.loads(line) for line in played.read_text().splitlines()[1:]]
    assert sorted({line["frame"] for line in lines if line["frame"] is not None}) == list(range(40))
