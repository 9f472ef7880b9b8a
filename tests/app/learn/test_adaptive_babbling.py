"""The adaptive plan in the real-time babbler (``facesynth learn --plan adaptive``): each
settled face is told to the plan, whose poses after the sweeps follow what the robot showed; a
resumed session replays its samples into the plan, which then continues as it would have."""

from __future__ import annotations

import asyncio
import io
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from facesynth.app.cli import main
from facesynth.app.learn.adaptive import AdaptiveOptions, AdaptivePlan
from facesynth.app.learn.cli import make_plan
from facesynth.app.learn.core import BabbleOptions, Babbler, Budget, Sample
from facesynth.app.learn.plan import PlanError, to_pulses
from facesynth.app.learn.plan_options import PlanChoice
from facesynth.app.learn.progress import Progress
from facesynth.app.learn.session import SessionFile, metadata, read_session
from facesynth.app.learn.settle import SettleOptions
from facesynth.app.learn.shell import RECORD_KEYS, BabbleShell, babble
from facesynth.app.wiring import StageParts
from facesynth.runtime.bus.memory import MemoryNetwork
from facesynth.runtime.profiles import load_profile
from facesynth.runtime.service import ServiceContext
from facesynth.schemas.messages import Features, ServoCommands
from facesynth.services.control.drivers.record import RecordConfig, RecordDriver
from facesynth.services.control.service import ControlService

MS = 1_000_000
TICK = 33 * MS
PROFILE = load_profile("paper16")
SERVOS = tuple(spec.name for spec in PROFILE.servos)
NEUTRAL = PROFILE.neutral_positions()
#: Small sweeps and batches, so a few dozen poses reach the region and least-sure poses.
OPTIONS = AdaptiveOptions(
    seed=2, sweep_steps=1, neutral_every=5, region_poses=6, batch=3, candidates=30
)

Face = Callable[[dict[str, float]], dict[str, float]]


def alone(positions: dict[str, float]) -> dict[str, float]:
    """A face in which each servo moves a feature of its own."""
    return {f"f_{name}": (value - NEUTRAL[name]) / 1000 for name, value in positions.items()}


def paired(positions: dict[str, float]) -> dict[str, float]:
    """A face in which servos 2k and 2k+1 move one feature together."""
    moved = [(positions[name] - NEUTRAL[name]) / 1000 for name in SERVOS]
    return {f"f_{name}": moved[i & ~1] + moved[i | 1] for i, name in enumerate(SERVOS)}


INPUTS = sorted(alone(NEUTRAL))
#: The adaptive plan a learn run below babbles: small sweeps, the other options the defaults.
CHOICE = PlanChoice("adaptive", 2, {"sweep_steps": 1, "neutral_every": 5})


class Told(AdaptivePlan):
    """The adaptive plan, keeping what it was told."""

    def __init__(self, options: AdaptiveOptions = OPTIONS) -> None:
        super().__init__(SERVOS, INPUTS, options)
        self.told: list[tuple[str, np.ndarray, np.ndarray]] = []

    def observe(self, kind: str, u: np.ndarray, face: np.ndarray) -> None:
        self.told.append((kind, np.array(u), np.array(face)))
        super().observe(kind, u, face)


def run(babbler: Babbler, face: Face = alone, *, seen_away: bool = True) -> list[Sample]:
    """Step the babbler against servos that follow at once and a face lagging a frame (seen
    only at neutral unless ``seen_away``); returns the samples."""
    positions, last, samples, now = dict(NEUTRAL), face(NEUTRAL), [], 0
    while not babbler.done and now < 600_000 * MS:
        babbler.servos(positions, now)
        visible = seen_away or positions == NEUTRAL
        if babbler.at_neutral:
            babbler.features(visible, last if visible else {}, True, now)
        last = face(positions)
        step = babbler.step(now)
        positions = dict(step.targets)
        if step.sample is not None:
            samples.append(step.sample)
        now += TICK
    assert babbler.done
    return samples


def test_the_babbler_tells_the_adaptive_plan_every_settled_face_in_order() -> None:
    plan = Told()
    samples = run(Babbler(PROFILE, plan, budget=Budget(poses=12)))
    assert [s.pose.index for s in samples] == list(range(12))
    assert plan.observed == 12 and len(plan.told) == 12
    for sample, (kind, u, face) in zip(samples, plan.told, strict=True):
        assert kind == sample.pose.kind and u.tolist() == list(sample.pose.u)
        assert face.tolist() == [sample.face.features[name] for name in INPUTS]
        assert sample.commanded == to_pulses(PROFILE, sample.pose.u)


@pytest.mark.parametrize(("face", "groups"), [(alone, 1), (paired, 2)], ids=["alone", "paired"])
def test_the_poses_after_the_sweeps_follow_the_faces_the_robot_showed(
    face: Face, groups: int
) -> None:
    plan = Told()
    sweeps = plan.base.sweep_poses
    samples = run(Babbler(PROFILE, plan, budget=Budget(poses=sweeps + 12)), face)
    assert len(samples) == sweeps + 12 and plan.observed == sweeps + 12
    # the regions are the robot's: one servo each, or the pairs that move one feature
    assert {len(group) for group in plan.regions.groups} == {groups}
    after = [s.pose for s in samples[sweeps:] if s.pose.kind != "neutral"]
    moved = [tuple(np.flatnonzero(np.abs(pose.u) > 0)) for pose in after]
    assert all(group in plan.regions.groups for group in moved[: OPTIONS.region_poses])
    assert any(len(group) == len(SERVOS) for group in moved[OPTIONS.region_poses :])
    for sample in samples:  # within every servo's limits, as the fixed plan's
        for spec in PROFILE.servos:
            assert spec.min_us <= sample.commanded[spec.name] <= spec.max_us


def test_a_pose_skipped_for_a_lost_face_is_told_as_not_seen() -> None:
    plan = Told()
    options = BabbleOptions(max_face_retries=0)
    babbler = Babbler(PROFILE, plan, budget=Budget(poses=4), options=options)
    samples = run(babbler, seen_away=False)
    assert babbler.skipped == 3 and [s.pose.index for s in samples] == [0]
    assert plan.observed == 4
    assert np.isfinite(plan.told[0][2]).all()
    assert all(np.isnan(face).all() for _, _, face in plan.told[1:])


def test_a_resumed_run_replays_its_samples_into_the_plan_and_continues_it() -> None:
    total = Told().base.sweep_poses + 12  # into the least-sure poses
    whole = run(Babbler(PROFILE, Told(), budget=Budget(poses=total)), paired)
    first = run(Babbler(PROFILE, Told(), budget=Budget(poses=30)), paired)
    plan = Told()
    plan.replay({s.pose.index: s.face.features for s in first}, 30)
    assert plan.observed == 30
    assert [face.tolist() for _, _, face in plan.told] == [
        [s.face.features[name] for name in INPUTS] for s in first
    ]
    rest = run(Babbler(PROFILE, plan, start=30, budget=Budget(poses=total)), paired)
    assert [s.pose.index for s in rest] == list(range(30, total))
    assert [s.commanded for s in first + rest] == [s.commanded for s in whole]
    # a plan not told the session's poses refuses to go on, rather than babble other poses
    with pytest.raises(PlanError, match="pose 30 told while pose 0 is the next"):
        run(Babbler(PROFILE, Told(), start=30, budget=Budget(poses=total)), paired)


async def _idle(ctx: ServiceContext) -> None:
    ctx.ready()
    await asyncio.Event().wait()


async def _camera(ctx: ServiceContext) -> None:
    """Camera, tracker and features in one: the face of the servos C reports."""
    states = ctx.subscribe("servo_state", 1, ServoCommands)
    ctx.ready()
    positions, seq = dict(NEUTRAL), 0
    while True:
        while (sample := states.receive_nowait()) is not None:
            positions = dict(sample.message.positions)
        seq += 1
        now = ctx.clock.time_ns()
        raw = paired(positions)
        ctx.publish(
            "features",
            Features(
                seq=seq, t_capture_ns=now, t_media_ns=seq, face=True, neutral_ready=True, raw=raw
            ),
        )
        await asyncio.sleep(0.02)


async def _learn(tmp: Path, poses: int) -> tuple[Any, AdaptivePlan]:
    """A run of ``facesynth learn --plan adaptive`` on an in-memory bus: the real control
    interface (record driver), recorder and session file; resumed if the file exists."""
    path = tmp / "s.mcap"
    resume = read_session(path) if path.exists() else None
    plan = make_plan(CHOICE, PROFILE, resume, tuple(INPUTS))
    assert isinstance(plan, AdaptivePlan)
    start = resume.next_pose if resume is not None else 0
    assert plan.observed == start
    settle = SettleOptions(frames=2, min_wait_s=0.05, max_wait_s=1.0, reach_timeout_s=3.0)
    babbler = Babbler(
        PROFILE,
        plan,
        start=start,
        budget=Budget(poses=poses),
        options=BabbleOptions(settle=settle, pace=1.0, hold_s=0.1),
    )
    progress = Progress(io.StringIO(), first=start, total=poses, started_s=0.0, tty=False)
    shell = BabbleShell(babbler, seed=2, progress=progress, on_neutral=lambda: None)
    session = SessionFile(path, metadata("self", PROFILE, 2, RECORD_KEYS, "adaptive"), resume)
    driver = RecordDriver(RecordConfig(out=str(tmp / "commands.jsonl")), PROFILE)
    control = ControlService(PROFILE, driver)
    parts = {
        "sensor": StageParts("sensor", "sensor", _idle),
        "points": StageParts("points", "points", _idle),
        "features": StageParts("features", "features", _camera),
        "control": StageParts("control", "control", control.serve, control),
    }
    result = await babble(MemoryNetwork().bus(), "self", parts, shell, session, frame_every=0)
    return result, plan


async def test_a_resumed_session_file_gives_the_adaptive_plan_its_earlier_samples(
    tmp_path: Path,
) -> None:
    result, plan = await _learn(tmp_path, 4)
    assert (result.taken, result.next_pose, plan.observed) == (4, 4, 4)
    session = read_session(tmp_path / "s.mcap")
    assert session.plan == "adaptive"
    resumed = make_plan(CHOICE, PROFILE, session, tuple(INPUTS))
    assert isinstance(resumed, AdaptivePlan) and resumed.observed == 4
    recorded = [[s.features[name] for name in INPUTS] for s in session.samples]
    np.testing.assert_array_equal(np.array(resumed._faces), recorded)  # told what was seen
    result, plan = await _learn(tmp_path, 7)
    assert (result.taken, result.next_pose, plan.observed) == (3, 7, 7)
    samples = read_session(tmp_path / "s.mcap").samples
    assert [s.seq for s in samples] == list(range(7))
    assert [s.kind for s in samples] == [
        "neutral",
        "sweep",
        "sweep",
        "sweep",
        "sweep",
        "neutral",
        "sweep",
    ]


def test_resuming_with_another_plan_is_one_clear_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    session = SessionFile(
        tmp_path / "s.mcap", metadata("self", PROFILE, 0, ["babble"], "adaptive"), None
    )
    session.writer.close()
    session.close()
    argv = ["learn", "--profile", "paper16", "--out", "s.mcap", "--video", "x", "--plan", "fixed"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.splitlines() == [
        "facesynth learn: error: s.mcap was babbled with --plan adaptive: resume it with that "
        "plan (or babble into a new file)"
    ]
