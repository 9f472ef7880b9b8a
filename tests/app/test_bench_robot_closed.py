"""The closed loop on a simulated head in virtual time: T → C → the head → its camera image →
the tracker → F → back to T. A learned profile is fitted here from the head's own babbling (in
process, by facesynth.app.learn.inprocess); the same performer segment plays
through it with the loop open and closed, on fresh heads."""

from __future__ import annotations

from collections.abc import Callable

import msgspec
import numpy as np
import pytest
from simhead16_laugh import HEAD, laughing, learned_simhead16

from facesynth.app.bench.robot import (
    Performance,
    RobotBench,
    RobotLoop,
    robot_features,
)
from facesynth.app.bench.robot_closed import CLOSED_SUFFIX, ClosedRobotLoop, bench_closed
from facesynth.app.bench.robot_compare import FeatureStream, compare, mark_reach, summarize
from facesynth.app.simhead import SimHead, load_head
from facesynth.runtime.clock import FAKE_EPOCH_NS
from facesynth.runtime.profiles import Profile, save_learned_profile
from facesynth.runtime.profiles.learned import shown_inputs
from facesynth.services.translator.learned import LearnedTargets

pytestmark = [pytest.mark.slow, pytest.mark.timeout(900)]


@pytest.fixture(scope="module")
def learned() -> Profile:
    return learned_simhead16()


@pytest.fixture(scope="module")
def performance() -> Performance:
    return laughing()  # she laughs


class RecordingHead(SimHead):
    """A simulated head that records every pulse it is sent and can lose its face (its
    camera then sees a blank image)."""

    def __init__(self) -> None:
        super().__init__(load_head(HEAD))
        self.sent: list[tuple[int, float]] = []
        self.blind_from_ns: int | None = None

    def command(self, channel: int, pulse_us: float) -> None:
        self.sent.append((channel, pulse_us))
        super().command(channel, pulse_us)

    def render(self) -> np.ndarray:
        image = super().render()
        if self.blind_from_ns is not None and self.t_ns >= self.blind_from_ns:
            return np.zeros_like(image)
        return image


def play(
    loop: RobotLoop, performance: Performance, on_frame: Callable[[int], None] | None = None
) -> FeatureStream:
    loop.start()
    frames = []
    for index, performer in enumerate(performance.features):
        if on_frame is not None:
            on_frame(index)
        _, features = loop.step(performer)
        frames.append(robot_features(features))
    return FeatureStream.from_frames(frames, names=performance.stream.names)


def target_error(profile: Profile, performance: Performance, robot: FeatureStream) -> float:
    """Mean absolute error of the robot's face to T's targets (the retargeted performer),
    over the features the robot can show, in units of its own spread of each."""
    assert profile.learned is not None
    targets = LearnedTargets(profile, {})
    assert targets.retargeter is not None
    shown = targets.retargeter.shown
    faces = np.stack([robot.column(name) for name in targets.inputs], axis=1)
    errors = []
    for index, performer in enumerate(performance.features):
        t = targets.retarget(performer.raw or {}, performer.named, performer.t_media_ns)
        if t is None or not performer.face:
            continue
        error = np.abs(faces[index] - t) / targets.scale
        errors.extend(error[shown & np.isfinite(error)])
    return float(np.mean(errors))


def test_the_closed_loop_beats_the_open_loop_on_the_same_head(
    learned: Profile, performance: Performance
) -> None:
    open_head, closed_head = RecordingHead(), RecordingHead()
    opened = play(RobotLoop(learned, open_head, fps=performance.fps), performance)
    loop = ClosedRobotLoop(learned, closed_head, fps=performance.fps)
    closed = play(loop, performance)
    rows = mark_reach([compare(performance.stream, opened), compare(performance.stream, closed)])
    open_summary, closed_summary = summarize(rows[0]), summarize(rows[1])
    assert closed_summary.mean_rho > open_summary.mean_rho + 0.01
    open_error = target_error(learned, performance, opened)
    closed_error = target_error(learned, performance, closed)
    assert closed_error < open_error
    assert loop.loop.state.updates > 0.9 * len(performance.features)
    # Never outside the profile's limits: every pulse the head was sent.
    for channel, pulse in closed_head.sent:
        spec = next(s for s in learned.servos if s.channel == channel)
        assert spec.min_us <= pulse <= spec.max_us


def test_a_lost_face_falls_back_to_the_open_loop(
    learned: Profile, performance: Performance
) -> None:
    head = RecordingHead()
    loop = ClosedRobotLoop(learned, head, fps=performance.fps)
    corrections: list[float] = []
    half = len(performance.features) // 2

    def on_frame(index: int) -> None:
        if index == half:  # the camera sees no face from now on
            head.blind_from_ns = head.t_ns
        corrections.append(float(np.abs(loop.loop.correction).max()))

    play(loop, performance, on_frame)
    assert max(corrections[:half]) > 0.05  # the loop was correcting
    steps = np.abs(np.diff(corrections))
    assert steps.max() <= loop.loop.options.max_step + 1e-9  # never a jump
    assert corrections[-1] == 0.0 and loop.loop.lost(FAKE_EPOCH_NS + loop.now_ns)  # open again


@pytest.fixture(scope="module")
def side_by_side(
    learned: Profile, performance: Performance, tmp_path_factory: pytest.TempPathFactory
) -> tuple[RobotBench, Profile]:
    """One ``bench robot --closed-loop`` run on the performer's first 30 frames (the two tests
    below read it, neither changes it): a written profile, a learned one named by its path, and
    one learned for the head (``learn``; returned too), each learned one open and closed."""
    path = f"{tmp_path_factory.mktemp('closed')}/robot.learned"
    save_learned_profile(msgspec.structs.replace(learned, name="robot"), path)
    short = Performance(
        performance.video,
        performance.fps,
        performance.features[:30],
        FeatureStream(performance.stream.names, performance.stream.values[:30]),
        performance.seconds,
    )
    mine = msgspec.structs.replace(learned, name="learned")
    result = bench_closed(
        short,
        [HEAD],
        ["head16", path],
        lambda name: SimHead(load_head(name)),
        learn=lambda h: [mine],
    )
    return result, mine


def test_bench_closed_puts_open_and_closed_side_by_side(
    side_by_side: tuple[RobotBench, Profile],
) -> None:
    """A learned profile named by its path runs open, then closed, after the written one."""
    result, _ = side_by_side
    names = [run.profile for run in result.heads[0].profiles]
    assert names[:3] == ["head16", "robot", "robot" + CLOSED_SUFFIX]


def test_bench_closed_runs_a_profile_learned_for_each_head_open_and_closed(
    side_by_side: tuple[RobotBench, Profile],
) -> None:
    """``bench robot --closed-loop --learn-poses N``: the profile learned for the head runs
    after the named ones, open and closed, and its babbling is what the head leads with."""
    result, mine = side_by_side
    (head,) = result.heads
    assert [run.profile for run in head.profiles] == [
        "head16",
        "robot",
        "robot" + CLOSED_SUFFIX,
        "learned",
        "learned" + CLOSED_SUFFIX,
    ]
    assert mine.learned is not None
    assert head.babbled == frozenset(shown_inputs(mine.learned))
