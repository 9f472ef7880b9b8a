"""Babbling session files: what is one, which profile it fits, its samples as a BabbleSet."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from facesynth.app.learn.session import (
    SessionError,
    SessionFile,
    babble_set,
    check_profile,
    metadata,
    read_session,
)
from facesynth.app.recording.layout import Layout
from facesynth.app.recording.writer import SessionWriter
from facesynth.runtime import codec
from facesynth.runtime.profiles import load_profile
from facesynth.schemas.messages import BabbleSample

KEY = "facesynth/self/babble"


def _sample(seq: int, features: dict[str, float], kind: str = "random") -> BabbleSample:
    profile = load_profile("paper16")
    return BabbleSample(
        seq=seq,
        t_capture_ns=1000 + seq,
        t_media_ns=seq,
        profile="paper16",
        kind=kind,
        commanded={**profile.neutral_positions(), "jaw": 1500.0 + seq},
        features=features,
    )


def _write(path: Path, samples: list[BabbleSample], meta: dict[str, str]) -> None:
    writer = SessionWriter(path, metadata=meta)
    layout = Layout()
    for index, sample in enumerate(samples):
        for entry in layout.entries(KEY, codec.encode(sample), 10 + index, index):
            writer.write(entry)
    writer.close()


def test_a_session_reads_back_with_its_samples_and_plan(tmp_path: Path) -> None:
    profile = load_profile("paper16")
    path = tmp_path / "s.mcap"
    samples = [_sample(0, {"a": 0.5}, "neutral"), _sample(1, {"a": 0.25, "b": 1.0})]
    _write(path, samples, metadata("self", profile, 9, ["babble"]))
    session = read_session(path)
    assert (session.rig, session.profile, session.seed, session.next_pose) == (
        "self",
        "paper16",
        9,
        2,
    )
    assert session.samples == samples
    check_profile(session, profile)
    data = babble_set(session.samples, profile)
    assert data.inputs == ("a", "b")
    assert np.isnan(data.faces[0, 1]) and data.faces[1].tolist() == [0.25, 1.0]
    assert data.commands[1, data.servos.index("jaw")] == 1501.0
    assert data.kinds == ("neutral", "random")
    with pytest.raises(SessionError, match="profile 'virtual' has other servos"):
        check_profile(session, load_profile("virtual"))


def test_a_resumed_session_keeps_the_old_messages_and_replaces_the_file(tmp_path: Path) -> None:
    profile = load_profile("paper16")
    path = tmp_path / "s.mcap"
    meta = metadata("self", profile, 9, ["babble"])
    _write(path, [_sample(0, {"a": 0.5})], meta)
    resumed = SessionFile(path, meta, read_session(path))
    assert resumed.copied == 1 and resumed.writing.name == "s.mcap.resume"
    for entry in Layout().entries(KEY, codec.encode(_sample(1, {"a": 0.1})), 20, 1):
        resumed.writer.write(entry)
    assert len(read_session(path).samples) == 1  # the old file stays as it was meanwhile
    resumed.writer.close()
    resumed.close()
    assert [s.seq for s in read_session(path).samples] == [0, 1]
    assert not resumed.writing.exists()


def test_a_recording_that_is_not_a_babbling_session_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "r.mcap"
    _write(path, [], {"rig": "self"})
    with pytest.raises(SessionError, match="a facesynth recording but not a babbling session"):
        read_session(path)
    bad = tmp_path / "bad.mcap"
    _write(bad, [], {**metadata("self", load_profile("paper16"), 1, []), "learn_seed": "x"})
    with pytest.raises(SessionError, match="names no plan seed"):
        read_session(bad)
    empty = tmp_path / "empty.mcap"
    empty.write_bytes(b"")
    with pytest.raises(SessionError, match=r"not a babbling session: .* empty file"):
        read_session(empty)
    torn = tmp_path / "torn.mcap"
    torn.write_bytes((tmp_path / "r.mcap").read_bytes()[:-40])
    with pytest.raises(SessionError, match="torn"):
        read_session(torn)
