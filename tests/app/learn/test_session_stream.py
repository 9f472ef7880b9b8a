"""A session that streamed: its frames read back beside its poses, paired at the head's lag,
and where a resumed run goes on (its plan after the last pose, its trajectory after the last
frame)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_session import _write

from facesynth.app.learn.session import babble_set, metadata, read_session
from facesynth.app.learn.stream import STREAM_KIND
from facesynth.runtime.profiles import load_profile
from facesynth.schemas.messages import BabbleSample

FRAME_NS = 33_333_333
START_NS = 5_000_000_000


def _pose(seq: int, jaw: float, kind: str = "sweep") -> BabbleSample:
    profile = load_profile("paper16")
    return BabbleSample(
        seq=seq,
        t_capture_ns=1_000_000_000 + seq * 100_000_000,
        t_media_ns=seq,
        profile="paper16",
        kind=kind,
        commanded={**profile.neutral_positions(), "jaw": jaw},
        features={"jaw_open": (jaw - 1500.0) / 500},
        settled=True,
    )


def _frame(index: int, gap_ns: int = 0) -> BabbleSample:
    """The jaw on a ramp of 1 µs a frame; the face shows the jaw's command itself."""
    profile = load_profile("paper16")
    jaw = 1500.0 + index
    return BabbleSample(
        seq=3,
        t_capture_ns=START_NS + index * FRAME_NS + gap_ns,
        t_media_ns=index,
        profile="paper16",
        kind=STREAM_KIND,
        commanded={**profile.neutral_positions(), "jaw": jaw},
        features={"jaw_open": jaw},
        frames=1,
        settled=False,
    )


def _samples() -> list[BabbleSample]:
    poses = [_pose(0, 1500.0, "neutral"), _pose(1, 1700.0), _pose(2, 1300.0)]
    first = [_frame(i) for i in range(30)]  # one second
    second = [_frame(i, 2_000_000_000) for i in range(30, 60)]  # another, after a 2 s gap
    return poses + second[::-1] + first  # in any order on the bus


def test_a_streamed_session_reads_back_its_frames_after_its_poses(tmp_path: Path) -> None:
    profile = load_profile("paper16")
    path = tmp_path / "s.mcap"
    _write(path, _samples(), metadata("self", profile, 4, ["babble"], "stream"))
    session = read_session(path)
    assert session.plan == "stream"
    assert session.next_pose == 3  # the frames are no poses of the plan
    # each second of stream: 29 frame periods; the 2 s gap between them is not stream
    assert session.streamed_s == pytest.approx(2 * 29 * FRAME_NS / 1e9)


def test_stream_frames_are_paired_with_the_commands_one_lag_earlier() -> None:
    profile = load_profile("paper16")
    lag_frames = 3
    babble = babble_set(_samples(), profile, {"jaw": lag_frames * FRAME_NS / 1e9})
    kinds = np.array(babble.kinds)
    assert list(kinds[:3]) == ["neutral", "sweep", "sweep"]
    stream = kinds == STREAM_KIND
    # the first lag's frames of each stretch have no command that far back: left out
    assert stream.sum() == 60 - 2 * lag_frames
    jaw = babble.commands[stream, babble.servos.index("jaw")]
    face = babble.faces[stream, babble.inputs.index("jaw_open")]
    np.testing.assert_allclose(jaw, face - lag_frames, atol=1e-6)
    # the poses keep their own commands; the stretches are numbered apart from them
    assert babble.commands[1, babble.servos.index("jaw")] == 1700.0
    stretches = babble.stretches()
    assert list(stretches[:3]) == [-1, -1, -1]
    assert stretches[stream].min() == 0 and len(set(stretches[stream])) >= 2
    assert babble.lags == {"jaw": lag_frames * FRAME_NS / 1e9}


def test_a_stream_without_a_measured_lag_is_paired_at_the_default() -> None:
    """No one-servo move measured a lag: the stream's default (about 3 frames)."""
    babble = babble_set(_samples(), load_profile("paper16"))
    stream = np.array(babble.kinds) == STREAM_KIND
    jaw = babble.commands[stream, babble.servos.index("jaw")]
    face = babble.faces[stream, babble.inputs.index("jaw_open")]
    np.testing.assert_allclose(face - jaw, 0.1 * 1e9 / FRAME_NS, atol=1e-6)
