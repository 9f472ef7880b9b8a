"""facesynth.app.bench.robot: the performer tracked once, a profile driving a head in process."""

from __future__ import annotations

import itertools
import math
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest

from facesynth.app.bench.robot import (
    Performance,
    RobotError,
    RobotLoop,
    bench_robot,
    run_profile,
    track_performer,
)
from facesynth.app.bench.robot_report import format_robot
from facesynth.app.data import sample_video
from facesynth.runtime.profiles import load_profile
from facesynth.services.points.tracker.offline import iter_video_frames

FRAMES = 36


@pytest.fixture(scope="module")
def performance() -> Performance:
    return track_performer(str(sample_video()), frames=FRAMES)


@pytest.fixture(scope="module")
def face_image() -> np.ndarray:
    image = next(iter(iter_video_frames(sample_video(), 1)))
    return np.ascontiguousarray(image[0:360, 140:500])


class StillHead:
    """A head whose face never moves; it records every command and step."""

    def __init__(self, image: np.ndarray) -> None:
        self.image = image
        self.now_ns = 0
        self.steps: list[int] = []
        self.commands: dict[int, list[tuple[int, float]]] = defaultdict(list)

    def command(self, channel: int, pulse_us: float) -> None:
        self.commands[channel].append((self.now_ns, pulse_us))

    def step(self, t_ns: int) -> None:
        assert t_ns >= self.now_ns, "time never goes back"
        self.now_ns = t_ns
        self.steps.append(t_ns)

    def render(self) -> np.ndarray:
        return self.image


def test_the_performer_is_tracked_once_with_raw_features(performance: Performance) -> None:
    assert len(performance.features) == FRAMES
    assert performance.fps == pytest.approx(23.976, abs=0.01)
    assert {"jaw_open", "eye_open_left", "mouthSmileLeft"} <= set(performance.stream.names)
    ready = [f.neutral_ready for f in performance.features]
    assert not ready[0] and ready[-1]  # F's neutral: the first second with a face
    assert np.isfinite(performance.stream.column("jaw_open")[-1])
    assert np.isnan(performance.stream.column("jaw_open")[0])


def test_a_profile_drives_the_head_within_c_limits(
    performance: Performance, face_image: np.ndarray
) -> None:
    profile = load_profile("paper16")
    head = StillHead(face_image)
    frames: list[int] = []
    robot = run_profile(performance, profile, head, on_frame=lambda i, image, f: frames.append(i))
    assert frames == list(range(FRAMES))
    assert robot.names == performance.stream.names and len(robot) == FRAMES
    # the neutral was learned on the still head: every frame has values, all at 0
    jaw = robot.column("jaw_open")
    assert np.isfinite(jaw).all() and np.abs(jaw).max() < 1e-6
    specs = {spec.channel: spec for spec in profile.servos}
    assert set(head.commands) == set(specs)
    for channel, sent in head.commands.items():
        spec = specs[channel]
        assert sent[0] == (0, spec.neutral_us)  # C starts at neutral
        for (t0, p0), (t1, p1) in itertools.pairwise(sent):
            assert spec.min_us <= p1 <= spec.max_us
            assert abs(p1 - p0) <= spec.max_speed * (t1 - t0) / 1e9 + 1e-6
    # C steps on its own clock between frames too (every MAX_STEP_S while chasing a target)
    period = 1e9 / performance.fps
    times = sorted({t for t, _ in head.commands[0]})
    assert any(abs((t - times[0]) / period - round((t - times[0]) / period)) > 0.01 for t in times)


def test_a_head_without_a_face_is_an_error(performance: Performance) -> None:
    loop = RobotLoop(load_profile("head16"), StillHead(np.zeros((320, 320, 3), np.uint8)), fps=30)
    with pytest.raises(RobotError, match=r"no face .* held at head16's neutral within 6 s"):
        loop.start()


def test_the_bench_marks_what_a_still_head_cannot_reach(
    performance: Performance, face_image: np.ndarray
) -> None:
    names: list[str] = []

    def open_head(name: str) -> StillHead:
        names.append(name)
        return StillHead(face_image)

    result = bench_robot(performance, ["still"], ["paper16", "head16"], open_head)
    assert names == ["still", "still"] and result.frames == FRAMES
    (head,) = result.heads
    assert head.head == "still" and [run.profile for run in head.profiles] == ["paper16", "head16"]
    for run in head.profiles:
        assert run.summary.moved > 0 and run.summary.reachable == 0
        assert math.isnan(run.summary.mean_rho) and run.summary.mean_rho_all == 0.0
    text = format_robot(result)
    assert "head still: 36 frames" in text and "mean rho, features it can reach" in text
    assert "paper16" in text and "head16" in text and " no " in text  # nothing reached
    with pytest.raises(RobotError, match="robo9"):
        bench_robot(performance, ["still"], ["robo9"], open_head)


def test_a_profile_with_channels_the_head_lacks_is_an_error() -> None:
    from facesynth.app.simhead import SimHead, load_head

    loop = RobotLoop(load_profile("arkit52"), SimHead(load_head("simhead16")), fps=30)
    with pytest.raises(RobotError, match=r"profile arkit52, servo \w+: channel 24 is not within"):
        loop.start()


def test_a_segment_plays_as_a_video_of_its_own() -> None:
    """From frame ``start`` on, media time from 0 there, F's neutral from its first second."""
    segment = track_performer(str(sample_video()), frames=30, start=200)
    assert len(segment.features) == 30
    assert segment.features[0].t_media_ns == 0 and segment.features[0].seq == 0
    assert not segment.features[0].neutral_ready and segment.features[-1].neutral_ready
    with pytest.raises(RobotError, match="0 or later"):
        track_performer(str(sample_video()), frames=3, start=-1)
    with pytest.raises(RobotError, match="never found the performer"):
        track_performer(str(sample_video()), frames=3, start=10_000)


def test_her_neutral_can_come_from_a_calibration(
    monkeypatch: pytest.MonkeyPatch, face_image: np.ndarray
) -> None:
    """``bench robot --calibration``: her change is read from the calibration's neutral from
    her first frame on (not from her first second, mid-grimace: her smile score is 0.49 in
    frame 0), T is given it too (as ``run --calibration`` gives it; the closed loop's T as well),
    and the report says so."""
    from facesynth.app.bench import robot as bench
    from facesynth.app.bench.robot import measure, performer_neutral
    from facesynth.app.bench.robot_compare import FeatureStream
    from facesynth.app.bench.robot_report import robot_json
    from facesynth.runtime.calibration import Calibration

    rest = Calibration(
        name="rest",
        neutral=[1.0] * 68,
        delta_min=[0.0] * 68,
        delta_max=[0.0] * 68,
        named_neutral={"mouthSmileLeft": 0.0, "eyeBlinkLeft": 0.0},
    )
    calibrated = track_performer(str(sample_video()), frames=4, calibration=rest)
    first = calibrated.features[0]
    assert calibrated.calibration is rest and first.neutral_ready
    assert first.raw["mouthSmileLeft"] == pytest.approx(0.49, abs=0.05)  # her score, from 0

    class Built(Exception):
        """The robot's loop was built (with these keyword arguments)."""

    def built(*args: object, **kwargs: object) -> None:
        raise Built(kwargs)

    monkeypatch.setattr(bench, "RobotLoop", built)
    with pytest.raises(Built) as loop:
        run_profile(calibrated, load_profile("paper16"), StillHead(face_image))
    assert loop.value.args[0]["calibration"] is rest
    from facesynth.app.bench import robot_closed

    monkeypatch.setattr(robot_closed, "ClosedRobotLoop", built)
    with pytest.raises(Built) as closed:  # the closed run of a profile is given it too
        robot_closed.run_closed(calibrated, load_profile("paper16"), StillHead(face_image))
    assert closed.value.args[0]["calibration"] is rest
    values = np.full(calibrated.stream.values.shape, np.nan)
    still = FeatureStream(calibrated.stream.names, values)
    result = measure(calibrated, ["still"], ["paper16"], lambda head, profile: still)
    told = "performer's neutral (her change is read from it): calibration 'rest'"
    assert told in format_robot(result)
    assert robot_json(result)["performer_neutral"] == "calibration 'rest' (its neutral step)"
    assert performer_neutral(None) == "her first second with a face"


def test_frames_must_be_positive() -> None:
    with pytest.raises(RobotError, match="--frames must be at least 1"):
        track_performer(str(sample_video()), frames=0)


def test_a_simulated_head_follows_the_performer_through_a_profile(
    performance: Performance,
) -> None:
    from facesynth.app.simhead import SimHead, load_head

    head = SimHead(load_head("simhead16"))
    images: list[np.ndarray] = []
    robot = run_profile(
        performance, load_profile("head16"), head, on_frame=lambda i, image, f: images.append(image)
    )
    assert len(images) == FRAMES and images[0].shape == (320, 320, 3)
    assert np.isfinite(robot.values).all(axis=1).any()  # the tracker sees the head's face
    # the performer's mouth moves in these frames (her brows are held: her first second is not
    # a resting brow, issue 20): so does the head's, which puckers through head16's lip corners
    moved = {
        name
        for name in robot.names
        if np.nanmax(robot.column(name)) - np.nanmin(robot.column(name)) > 0.05
    }
    assert "mouthPucker" in moved
    corners = [spec for spec in load_profile("head16").servos if "lip_corner" in spec.name]
    assert any(head.pulses()[spec.channel] != spec.neutral_us for spec in corners)


def test_the_command_prints_a_table_and_writes_json(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import json

    from facesynth.app.cli import main

    out = tmp_path / "deep" / "robot.json"
    argv = ["bench", "robot", "--frames", "30", "--head", "simhead16", "--profile", "paper16"]
    assert main([*argv, "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "head simhead16: 30 frames" in text and "mean rho, features it can reach" in text
    result = json.loads(out.read_text())
    assert result["frames"] == 30 and result["moved_span"]["inter-ocular distance"] == 0.02
    (head,) = result["heads"]
    (run,) = head["profiles"]
    assert head["head"] == "simhead16" and run["profile"] == "paper16"
    assert set(run["summary"]) == {
        "moved",
        "reachable",
        "mean_rho",
        "mean_rho_all_moved",
        "median_ratio",
        "in_band",
    }
    assert {"feature", "rho", "ratio", "reachable", "moved"} <= set(run["features"][0])
    assert isinstance(run["best_lag_frames"], int)


def test_the_table_keeps_long_profile_names_apart() -> None:
    from facesynth.app.bench.robot import HeadRun, ProfileRun, RobotBench
    from facesynth.app.bench.robot_compare import FeatureRow, summarize

    rows = [FeatureRow("jaw_open", "inter-ocular distance", 100, 0.2, 0.1, 0.5, 0.5, True)]
    names = ("paper16", "simhead16_reversed_learned", "x.learned")
    runs = [ProfileRun(name, rows, summarize(rows), 1.0, 2, 0.5) for name in names]
    text = format_robot(RobotBench("v", 100, 24.0, "full", 1.0, [HeadRun("h", runs)]))
    header = next(line for line in text.splitlines() if "paper16" in line)
    assert "paper16 " in header and "simhead16_reversed_learned  x.learned" in header
    assert "best lag, frames (mean rho there)" in text and "2 (0.50)" in text
