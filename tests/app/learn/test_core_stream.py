"""The babbler's streaming phase, time as data: after the sweeps the head keeps moving along the
stream's trajectory and every frame with a face comes back with the commands in force when it
was taken."""

from __future__ import annotations

import numpy as np

from facesynth.app.learn.core import BabbleOptions, Babbler, Budget, Sample
from facesynth.app.learn.plan import Plan, PlanOptions
from facesynth.app.learn.stream import StreamFrame, Streaming, Trajectory
from facesynth.runtime.profiles import Profile, load_profile

MS = 1_000_000
TICK = 33 * MS


def _profile() -> Profile:
    return load_profile("paper16")


def _babbler(until_s: float, start: int | None = None) -> tuple[Babbler, Plan]:
    profile = _profile()
    plan = Plan(len(profile.servos), PlanOptions(seed=0, sweep_steps=1))
    stream = Streaming(
        plan.sweep_poses if start is None else start, Trajectory(len(profile.servos), 3)
    )
    budget = Budget(until_ns=round(until_s * 1e9))
    return Babbler(profile, plan, budget=budget, options=BabbleOptions(), stream=stream), plan


def _face(profile: Profile, positions: dict[str, float]) -> dict[str, float]:
    neutral = profile.neutral_positions()
    return {f"f_{k}": (v - neutral[k]) / 1000 for k, v in positions.items()}


def _run(
    babbler: Babbler, until_s: float, hide: tuple[float, float] | None = None
) -> tuple[list[Sample], list[StreamFrame], list[str], list[dict[str, float]]]:
    """Servos that follow at once; each tick the camera's frame of the last tick (taken just
    after its command) arrives, stamped with when it was taken (hidden between ``hide``
    seconds)."""
    profile = babbler.profile
    positions = profile.neutral_positions()
    samples: list[Sample] = []
    frames: list[StreamFrame] = []
    phases: list[str] = []
    commands: list[dict[str, float]] = []
    taken: tuple[int, dict[str, float]] | None = None
    now = 0
    while now < until_s * 1e9 and not babbler.done:
        visible = hide is None or not hide[0] * 1e9 <= now < hide[1] * 1e9
        babbler.servos(positions, now)
        if babbler.at_neutral and taken is not None:
            babbler.features(visible, _face(profile, taken[1]) if visible else {}, True, taken[0])
        step = babbler.step(now)
        if not phases or phases[-1] != step.phase:
            phases.append(step.phase)
        positions = dict(step.targets)
        taken = (now + MS, dict(positions))  # the frame just after the servos got there
        commands.append(positions)
        if step.sample is not None:
            samples.append(step.sample)
        frames.extend(step.frames)
        now += TICK
    return samples, frames, phases, commands


def test_after_the_sweeps_the_babbler_streams_until_its_time_is_spent() -> None:
    """The sweeps are settled poses; then streaming, no more poses, until the budget ends it
    back at neutral."""
    babbler, plan = _babbler(until_s=60.0)
    samples, frames, phases, commands = _run(babbler, until_s=80.0)
    sweeps, during = samples[: plan.sweep_poses], samples[plan.sweep_poses :]
    assert {s.pose.kind for s in sweeps} == {"sweep", "neutral"}
    # while streaming, a settled neutral every 20 s (the fit's noise and drift), nothing else
    assert {s.pose.kind for s in during} == {"neutral"}
    began = min(f.t_ns for f in frames)
    assert len(during) == int((60e9 - began) // 20e9)
    gaps = np.diff([began] + [s.t_ns for s in during]) / 1e9
    assert np.all((gaps > 20.0) & (gaps < 23.0)), gaps
    assert [s.pose.index for s in during] == list(range(plan.sweep_poses, len(samples)))
    assert phases[-3:] == ["streaming", "finishing", "done"]
    assert babbler.streamed == len(frames) > 100
    assert commands[-1] == babbler.profile.neutral_positions()


def test_each_streamed_frame_carries_the_commands_in_force_when_it_was_taken() -> None:
    """The simulated face is the servos' offsets at the frame's instant, which the servos
    reached at the command sent then: every frame's commands give back its face."""
    babbler, _ = _babbler(until_s=40.0)
    _, frames, _, _ = _run(babbler, until_s=45.0)
    assert frames
    for frame in frames:
        assert frame.features == _face(babbler.profile, frame.commanded)
    times = [frame.t_ns for frame in frames]
    assert times == sorted(times)


def test_the_stream_moves_every_servo_both_ways_within_its_pace() -> None:
    """The trajectory takes each servo above and below neutral, and no command moves faster
    than the pace allows."""
    babbler, _ = _babbler(until_s=90.0)
    _, frames, _, commands = _run(babbler, until_s=95.0)
    profile = babbler.profile
    neutral = profile.neutral_positions()
    for spec in profile.servos:
        values = np.array([frame.commanded[spec.name] for frame in frames])
        assert values.max() > neutral[spec.name] + 1 and values.min() < neutral[spec.name] - 1
        assert values.max() <= spec.max_us and values.min() >= spec.min_us
        steps = np.abs(np.diff([c[spec.name] for c in commands]))
        assert steps.max() <= babbler.speeds[spec.name] * TICK / 1e9 + 1e-6


def test_a_lost_face_pauses_the_stream_and_it_goes_on_when_the_face_is_back() -> None:
    """No frames while the face is away; the servos go back to neutral; the stream resumes
    (no pose of the plan is skipped for it)."""
    babbler, _ = _babbler(until_s=70.0, start=0)
    samples, frames, phases, commands = _run(babbler, until_s=75.0, hide=(30.0, 35.0))
    assert commands[int(34e9 // TICK)] == babbler.profile.neutral_positions()
    assert "paused" in phases
    assert phases[phases.index("paused") + 1] == "streaming"
    assert not [f for f in frames if 30.0e9 <= f.t_ns < 35.0e9]
    assert [f for f in frames if f.t_ns > 36.0e9]
    # the only poses taken are the stream's neutrals; none skipped for the lost face
    assert babbler.skipped == 0 and babbler.index == babbler.taken == len(samples) >= 2
    assert {s.pose.kind for s in samples} == {"neutral"}


def test_a_frame_taken_before_the_stream_began_is_left_out() -> None:
    """A frame stamped before any streaming command has no commands to pair: not kept."""
    babbler, _ = _babbler(until_s=30.0, start=0)
    now = 0
    while babbler.phase != "streaming":
        babbler.servos(babbler.commanded, now)
        babbler.features(True, {"f_x": 0.0}, True, now)
        babbler.step(now)
        now += TICK
    babbler.features(True, {"f_x": 1.0}, True, now - 10 * TICK)
    assert babbler.step(now).frames == ()
    babbler.features(True, {"f_x": 2.0}, True, now)
    (frame,) = babbler.step(now + TICK).frames
    assert frame.features == {"f_x": 2.0} and frame.t_ns == now
