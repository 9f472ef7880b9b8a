"""Fuzz the file readers: track files (JSON lines), OpenFace CSV, record files (JSON lines with
session markers) and MCAP recordings (``facesynth record``)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import msgspec
import numpy as np
import pytest
from fuzzing import FUZZ, TIMEOUT, check_tally, outcome, scratch_folder
from hypothesis import given
from hypothesis import strategies as st
from mutations import damaged, damaged_text, mutated, to_json

from facesynth.app.recording.check import scan
from facesynth.app.recording.layout import Layout
from facesynth.app.recording.reader import Recording, RecordingError
from facesynth.app.recording.writer import SessionWriter
from facesynth.runtime import blendshapes, codec
from facesynth.runtime.frames import encode_frame
from facesynth.schemas.messages import Features, Frame, Points, PointSet, ServoCommands
from facesynth.services.control.drivers.record import RecordError, read_sessions
from facesynth.services.points.backends.base import BackendError
from facesynth.services.points.backends.track import TrackFileConfig, TrackReplay
from facesynth.services.points.openface_csv import OpenFaceError, parse_openface_csv

pytestmark = [pytest.mark.fuzz, TIMEOUT]

ROOT = Path(__file__).resolve().parents[2]
FOLDER = scratch_folder("facesynth-fuzz-files-")


def _lines(trees: list[Any]) -> bytes:
    return b"".join(to_json(tree) + b"\n" for tree in trees)


def json_lines(trees: list[Any]) -> st.SearchStrategy[bytes]:
    """The lines of ``trees`` with some mutated, damaged as a whole, or random bytes."""
    # What a file draws from, built once (not again inside every draw).
    whole = _lines(trees)
    kinds = st.sampled_from(["mutate", "mutate", "damage", "random", "valid"])
    damages, randoms = damaged(whole), st.binary(max_size=200)
    lines = st.sets(st.integers(0, len(trees) - 1), min_size=1, max_size=2)
    changes = [mutated(tree, max_changes=2) for tree in trees]

    @st.composite
    def files(draw: st.DrawFn) -> bytes:
        kind = draw(kinds)
        if kind == "damage":
            return draw(damages)
        if kind == "random":
            return draw(randoms)
        if kind == "valid":
            return whole
        changed = list(trees)
        for index in draw(lines):
            changed[index] = draw(changes[index])
        return _lines(changed)

    return files()


# --- track files -------------------------------------------------------------------------------

GRID = [[100.0 + (i % 17) * 5.0, 80.0 + (i // 17) * 6.0] for i in range(68)]
TRACK = [
    {"frame": 0, "face": False, "presence": 0.1},
    {
        "frame": 1,
        "face": True,
        "ibug68": GRID,
        "mesh": [[100.0 + i % 26, 80.0 + i // 26, 0.5] for i in range(468)],
        "iris": [[120.0 + i, 90.0] for i in range(10)],
        "presence": 0.98,
        "blendshapes": [0.25] * blendshapes.COUNT,
    },
    {"frame": 2, "face": True, "ibug68": GRID},
]
FRAME = Frame(seq=0, t_capture_ns=0, t_media_ns=0, width=640, height=360, encoding="none")


def test_track_files_replay_or_raise_backend_error() -> None:
    target = "points.backends.track (track file)"
    file = FOLDER / "face.track.jsonl"

    @FUZZ
    @given(json_lines(TRACK))
    def case(data: bytes) -> None:
        file.write_bytes(data)
        replay = outcome(target, lambda: TrackReplay(TrackFileConfig(path=str(file))), BackendError)
        if replay is None:
            return
        for seq in range(replay.frame_count()):
            points = replay.process(msgspec.structs.replace(FRAME, seq=seq))
            codec.decode(codec.encode(points), Points)  # what P publishes is valid

    case()
    check_tally(target, "valid", "refused")


# --- OpenFace CSV ------------------------------------------------------------------------------

CSV_LINES = (ROOT / "facesynth/app/data/OpenFace_Test.csv").read_text().splitlines()[:4]
CSV_ROWS = [line.split(",") for line in CSV_LINES]
CELLS = ["", " ", "nan", "inf", "-inf", "1e999", "-1", "0.5", "abc", '"', "1,2", "\x00", "2.5e3"]


# What a CSV text draws from, built once (not again inside every draw).
_CSV_KINDS = st.sampled_from(["cells", "cells", "damage", "random"])
_CSV_DAMAGES = damaged_text("\n".join(CSV_LINES))
_CSV_RANDOM = st.text(max_size=200)
_CSV_EDITS = st.integers(1, 4)
_CSV_ROWS = st.integers(0, len(CSV_ROWS) - 1)
_CSV_ACTIONS = st.sampled_from(["set", "set", "drop", "add"])
_CSV_CELLS = st.sampled_from(CELLS)
_CSV_SET = st.one_of(_CSV_CELLS, st.text(max_size=5))


@st.composite
def openface_texts(draw: st.DrawFn) -> str:
    kind = draw(_CSV_KINDS)
    if kind == "damage":
        return draw(_CSV_DAMAGES)
    if kind == "random":
        return draw(_CSV_RANDOM)
    rows = [list(row) for row in CSV_ROWS]
    for _ in range(draw(_CSV_EDITS)):
        row = rows[draw(_CSV_ROWS)]
        column = draw(st.integers(0, len(row) - 1))
        action = draw(_CSV_ACTIONS)
        if action == "set":
            row[column] = draw(_CSV_SET)
        elif action == "drop":
            del row[column]
        else:
            row.insert(column, draw(_CSV_CELLS))
    return "\n".join(",".join(row) for row in rows)


def test_openface_csv_parses_or_raises_openface_error() -> None:
    target = "points.openface_csv"

    @FUZZ
    @given(openface_texts())
    def case(text: str) -> None:
        rows = outcome(target, lambda: parse_openface_csv(text), OpenFaceError)
        for row in rows or []:
            assert row.points.shape == (68, 2) and np.all(np.isfinite(row.points))
            assert row.frame >= 0 and math.isfinite(row.confidence)

    case()
    check_tally(target, "valid", "refused")


# --- record files ------------------------------------------------------------------------------

MARKER = {"session": {"started_ns": 1, "profile": "paper16", "host": "h", "pid": 7}}
LINE = {
    "seq": 0,
    "frame": 3,
    "t_capture_ns": 10,
    "t_sent_ns": 20,
    "face": True,
    "servos": {"jaw": 1500.0, "right_eyebrow": 1400.5},
}
RECORD = [LINE, MARKER, LINE, dict(LINE, seq=1, frame=None, t_capture_ns=None)]


def test_record_files_read_or_raise_record_error() -> None:
    target = "control.drivers.record.read_sessions"
    file = FOLDER / "commands.jsonl"

    @FUZZ
    @given(json_lines(RECORD))
    def case(data: bytes) -> None:
        file.write_bytes(data)
        sessions = outcome(target, lambda: read_sessions(file), RecordError)
        for session in sessions or []:
            for line in session.lines:
                assert isinstance(line.servos, dict)

    case()
    check_tally(target, "valid", "refused")


# --- MCAP recordings ---------------------------------------------------------------------------


def _recording(path: Path) -> bytes:
    """A small, complete recording: a JPEG frame, points, features, commands (3 frames)."""
    layout = Layout()
    writer = SessionWriter(path, metadata={"rig": "default"}, fsync=False, chunk_bytes=2048)
    image = np.full((24, 32, 3), 90, np.uint8)
    for seq in range(3):
        t = 1_700_000_000_000_000_000 + seq * 33_333_333
        items = [
            ("input", encode_frame(image, seq=seq, t_capture_ns=t, t_media_ns=seq)),
            (
                "points",
                Points(
                    seq=seq,
                    t_capture_ns=t,
                    t_media_ns=seq,
                    face=True,
                    image_width=32,
                    image_height=24,
                    sets=[PointSet(scheme="ibug68", dims=2, coords=[1.0] * 136)],
                ),
            ),
            ("features", Features(seq=seq, t_capture_ns=t, t_media_ns=seq, face=False)),
            (
                "servo_commands",
                ServoCommands(
                    seq=seq,
                    t_capture_ns=t,
                    t_media_ns=seq,
                    face=True,
                    profile="paper16",
                    positions={"jaw": 1500.0},
                ),
            ),
        ]
        for index, (stage, message) in enumerate(items):
            key = f"facesynth/default/{stage}"
            for entry in layout.entries(key, codec.encode(message), t + index, seq * 10 + index):
                writer.write(entry)
    writer.close()
    return path.read_bytes()


def test_recordings_read_or_raise_recording_error() -> None:
    target = "recording.Recording (MCAP)"
    scan_target = "recording.check.scan (MCAP)"
    valid = _recording(FOLDER / "valid.mcap")
    file = FOLDER / "fuzzed.mcap"

    def read() -> int:
        with Recording(file) as recording:
            return sum(1 for _ in recording.messages(recording.bus_keys()))

    @FUZZ
    @given(st.one_of(damaged(valid), damaged(valid), st.binary(max_size=64), st.just(valid)))
    def case(data: bytes) -> None:
        file.write_bytes(data)
        outcome(target, read, RecordingError)
        outcome(scan_target, lambda: scan(file), RecordingError)

    case()
    check_tally(target, "valid", "refused")
    check_tally(scan_target, "valid", "refused")
