"""The calibration recorder (pure core) and ``facesynth calibrate``'s error handling."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pytest
from synthetic_face import IRIS, MESH, S, move, points_message, transform

from facesynth.app.calibrate_cli import guided_schedule
from facesynth.app.cli import main
from facesynth.app.data import sample_openface_csv
from facesynth.runtime.calibration import load_calibration, validate_calibration
from facesynth.schemas.messages import Points
from facesynth.services.features.calibrate import (
    PROMPTS,
    STEPS,
    CalibrationRecorder,
    CalibrationStepError,
    parse_schedule,
    step_at,
)
from facesynth.services.features.expressions import BROW, raw_features

CSV = str(sample_openface_csv())


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("neutral=0-1,smile", "is not STEP=START-END"),
        ("neutral=0-1,dance=1-2", "unknown step 'dance'"),
        ("neutral=2-1", "ends before it starts"),
        ("neutral=0-2,smile=1-3", "steps 'neutral' and 'smile' overlap"),
        ("smile=0-2", "needs a neutral step"),
        ("", "needs a neutral step"),
        ("neutral=-1-2", "is not STEP=START-END"),
    ],
    ids=["no-times", "unknown-step", "backwards", "overlap", "no-neutral", "empty", "negative"],
)
def test_bad_schedules(text: str, message: str) -> None:
    with pytest.raises(CalibrationStepError, match=message):
        parse_schedule(text)


def test_schedule_is_sorted_and_looked_up() -> None:
    schedule = parse_schedule("smile=5-6.5, neutral=0-2")
    assert schedule == [("neutral", 0.0, 2.0), ("smile", 5.0, 6.5)]
    assert step_at(schedule, 1.0) == ("neutral", 1.0)
    assert step_at(schedule, 5.5) == ("smile", 0.5)
    assert step_at(schedule, 3.0) is None and step_at(schedule, 6.5) is None


def _frames(recorder: CalibrationRecorder, step: str, mesh: np.ndarray, count: int) -> None:
    for i in range(count):
        recorder.add(step, i / 30, points_message(mesh, IRIS, seq=i, t_media_ns=i * S // 30))


def test_recorder_measures_neutral_and_ranges() -> None:
    recorder = CalibrationRecorder("alice", raw_features, settle_s=0.1)
    _frames(recorder, "neutral", MESH, 20)
    raised = move(MESH, BROW["right"].mesh, dy=0.06)
    _frames(recorder, "raise_eyebrows", raised, 20)
    calibration = recorder.build(created="2026-11-22")
    assert validate_calibration(calibration) == []
    assert recorder.summary() == {"neutral": (17, 20), "raise_eyebrows": (17, 20)}
    assert len(calibration.neutral_mesh) == 468 * 3
    assert calibration.named_max["brow_raise_inner_right"] == pytest.approx(0.06, abs=0.005)
    # A feature that did not move keeps a quarter of its default range (never zero-width).
    assert 0 < calibration.named_max["jaw_open"] < 0.1
    assert max(calibration.delta_max[17:22]) > 0.03  # the paper's brow distances grew
    assert max(abs(v) for v in calibration.delta_min[48:68]) < 1e-6  # the mouth did not move


def test_a_nodding_head_widens_no_paper_range() -> None:
    """The paper's distances are read with the head's rotation since the neutral mesh taken
    out (issue 27, F's ``frontal.paper_frame``): a step done with the head nodding and turned
    but the face still moves none of the 68 ranges (the yaw alone undone: the chin-up read as
    brows lowered)."""
    recorder = CalibrationRecorder("alice", raw_features, settle_s=0.1)
    _frames(recorder, "neutral", MESH, 20)
    nodding, _ = transform(MESH, IRIS, yaw=15.0, pitch=12.0, scale=0.9, shift=(20, 5, 0))
    _frames(recorder, "look_up", nodding, 20)
    calibration = recorder.build(created="2026-11-26")
    assert max(abs(v) for v in calibration.delta_min + calibration.delta_max) < 1e-6


def test_recorder_needs_a_neutral_with_a_face() -> None:
    recorder = CalibrationRecorder("bob", raw_features)
    no_face = Points(
        seq=0, t_capture_ns=1, t_media_ns=1, face=False, image_width=640, image_height=480
    )
    for i in range(30):
        recorder.add("neutral", 1.0 + i / 30, no_face)
    _frames(recorder, "smile", MESH, 30)
    with pytest.raises(CalibrationStepError, match="neutral step has fewer than 3 usable frames"):
        recorder.build()
    assert recorder.summary()["neutral"] == (0, 30)


def test_recorder_skips_the_settling_time() -> None:
    recorder = CalibrationRecorder("carol", raw_features, settle_s=0.7)
    assert not recorder.add("neutral", 0.5, points_message(MESH, IRIS, seq=0, t_media_ns=0))
    assert recorder.add("neutral", 0.8, points_message(MESH, IRIS, seq=1, t_media_ns=1))


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["calibrate", "a/b", "--ticks", "3"], "invalid calibration name"),
        (["calibrate", "dana", "--video", "/nonexistent.mp4"], "does not exist"),
        (["calibrate", "dana", "--openface-csv", CSV], "give --schedule"),
        (
            ["calibrate", "dana", "--openface-csv", CSV, "--schedule", "smile=0-1"],
            "needs a neutral step",
        ),
        (
            ["calibrate", "dana", "--ticks", "3", "--schedule", "neutral=0-1"],
            "the tracker needs images",
        ),
        (
            ["calibrate", "dana", "--openface-csv", CSV, "--schedule", "neutral=0-0.05"],
            "fewer than 3 usable",
        ),
    ],
    ids=[
        "bad-name",
        "missing-video",
        "recording-without-schedule",
        "schedule-without-neutral",
        "tracker-without-pixels",
        "neutral-too-short",
    ],
)
def test_calibrate_cli_errors(
    argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "facesynth calibrate: error: " in err and message in err
    assert "Traceback" not in err


def test_calibrate_from_a_track_replay_writes_a_loadable_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # A replayed recording needs no pixels: ticks drive it, as in `facesynth run`.
    def ibug(mesh: np.ndarray) -> list[list[float]]:
        coords = points_message(mesh, IRIS, seq=0, t_media_ns=0).sets[0].coords
        return np.asarray(coords).reshape(68, 2).tolist()

    neutral, raised = ibug(MESH), ibug(move(MESH, BROW["right"].mesh, dy=0.06))
    track = tmp_path / "track.jsonl"
    track.write_text(
        "".join(
            json.dumps({"frame": i, "face": True, "ibug68": neutral if i < 30 else raised}) + "\n"
            for i in range(60)
        )
    )
    out = tmp_path / "cal.json"
    argv = [
        "calibrate",
        "erin",
        "--points-jsonl",
        str(track),
        "--schedule",
        "neutral=0-1,raise_eyebrows=1-2",
        "--out",
        str(out),
    ]
    assert main(argv) == 0, capsys.readouterr().err
    assert "calibration 'erin' written" in capsys.readouterr().out
    calibration = load_calibration(str(out))
    assert max(calibration.delta_max[17:22]) > 0.03
    assert calibration.neutral_mesh == []  # 68 points only: no mesh to take a neutral from


def test_failed_calibration_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "cal.json"
    argv = [
        "calibrate",
        "fay",
        "--openface-csv",
        CSV,
        "--schedule",
        "neutral=0-0.05",
        "--out",
        str(out),
    ]
    assert main(argv) == 2
    assert "fewer than 3 usable" in capsys.readouterr().err
    assert not out.exists()


def _args(**values: object) -> argparse.Namespace:
    defaults = {"schedule": None, "steps": ",".join(STEPS), "seconds": 4.0}
    return argparse.Namespace(**{**defaults, **values})


def test_live_guidance_is_ten_steps_in_under_a_minute() -> None:
    schedule = guided_schedule(_args(), live=True)
    assert [step for step, _, _ in schedule] == list(STEPS) and len(STEPS) == 10
    assert schedule[0] == ("neutral", 0.0, 4.0) and schedule[-1] == ("smile", 36.0, 40.0)
    assert schedule[-1][2] < 60, "a new performer calibrates in under a minute"
    assert all(step in PROMPTS for step in STEPS)


@pytest.mark.parametrize(
    ("values", "message"),
    [
        ({"steps": "smile,frown"}, "needs neutral"),
        ({"steps": "neutral,juggle"}, "known steps"),
        ({"seconds": 1.0}, "at least 1.5"),
    ],
    ids=["no-neutral", "unknown-step", "too-short"],
)
def test_live_guidance_errors(values: dict[str, object], message: str) -> None:
    with pytest.raises(CalibrationStepError, match=message):
        guided_schedule(_args(**values), live=True)


def test_a_recording_needs_a_schedule_but_takes_one() -> None:
    with pytest.raises(CalibrationStepError, match="give --schedule"):
        guided_schedule(_args(), live=False)
    assert guided_schedule(_args(schedule="neutral=1-2"), live=False) == [("neutral", 1.0, 2.0)]
