"""Offline video tracking to a track file, and corrupt videos."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from tracker_fixtures import VIDEO, VIDEO_FRAMES, TrackedVideo

from facesynth.schemas.messages import Frame
from facesynth.services.points.backends.track import TrackFileConfig, TrackReplay
from facesynth.services.points.track_file import TrackLine, encode_line
from facesynth.services.points.tracker import FaceTracker, VideoError, track_video
from facesynth.services.points.tracker.offline import iter_video_frames, result_to_line


def test_track_video_writes_one_line_per_frame(
    tmp_path: Path, tracker: FaceTracker, tracked_video: TrackedVideo
) -> None:
    out = tmp_path / "sub" / "points.jsonl"
    summary = track_video(VIDEO, out, tracker=tracker)
    assert summary["frames"] == summary["faces"] == VIDEO_FRAMES
    assert summary["lost_frames"] == []
    assert summary["backend"] == "litert" and summary["detector_runs"] == 16
    assert 0 < summary["tracker_ms_median"] <= summary["tracker_ms_p99"]
    lines = out.read_text(encoding="utf-8").splitlines()
    assert len(lines) == VIDEO_FRAMES
    assert [p.name for p in out.parent.iterdir()] == ["points.jsonl"]  # no temp file left
    for i, line in enumerate(lines):
        rec = json.loads(line)
        assert list(rec) == ["frame", "face", "mesh", "iris", "ibug68", "presence", "blendshapes"]
        assert rec["blendshapes"] is None  # the fast model has none
        assert rec["frame"] == i and rec["face"] is True
        ref = tracked_video.results[i]
        assert rec["presence"] == round(float(ref.presence), 4)
        for key, n in (("mesh", 468), ("iris", 10), ("ibug68", 68)):
            pts = np.array(rec[key])
            assert pts.shape == (n, 2)
            np.testing.assert_allclose(pts, getattr(ref, key)[:, :2], atol=0.0051)
            assert np.allclose(pts * 100, np.round(pts * 100), atol=1e-6)  # 2 decimals


def test_no_face_lines_are_null(tmp_path: Path, tracker: FaceTracker) -> None:
    r = tracker.process(np.zeros((120, 160, 3), np.uint8))
    line = result_to_line(7, r)
    assert line == TrackLine(frame=7, face=False, presence=0.0)
    assert encode_line(line) == (
        b'{"frame":7,"face":false,"mesh":null,"iris":null,"ibug68":null,"presence":0.0,'
        b'"blendshapes":null}\n'
    )


def test_the_replay_reads_what_the_tracker_wrote(tmp_path: Path, tracker: FaceTracker) -> None:
    """Writer and reader share TrackLine: a replay gives the tracked points and presence."""
    out = tmp_path / "points.jsonl"
    track_video(VIDEO, out, tracker=tracker)
    replay = TrackReplay(TrackFileConfig(path=str(out)))
    assert replay.frame_count() == VIDEO_FRAMES
    lines = out.read_bytes().splitlines()
    for seq in (0, 1, VIDEO_FRAMES - 1):
        rec = json.loads(lines[seq])
        frame = Frame(seq=seq, t_capture_ns=1, t_media_ns=0, width=640, height=360, encoding="none")
        points = replay.process(frame)
        assert points.face and points.confidence == rec["presence"]
        by_scheme = {s.scheme: np.reshape(s.coords, (-1, s.dims)) for s in points.sets}
        for scheme, key in (("ibug68", "ibug68"), ("mesh468", "mesh"), ("iris10", "iris")):
            np.testing.assert_array_equal(by_scheme[scheme], rec[key])


def _truncated(p: Path) -> None:
    data = VIDEO.read_bytes()
    p.write_bytes(data[: len(data) // 2])


def _header_only(p: Path) -> None:
    p.write_bytes(VIDEO.read_bytes()[:5000])


def _garbage(p: Path) -> None:
    p.write_bytes(b"\x00garbage, not a video\xff" * 5000)


def _zeroed_middle(p: Path) -> None:
    data = bytearray(VIDEO.read_bytes())
    data[400_000:600_000] = bytes(200_000)
    p.write_bytes(bytes(data))


def _empty(p: Path) -> None:
    p.write_bytes(b"")


def _missing(p: Path) -> None:
    pass


@pytest.mark.parametrize(
    "make, message",
    [
        (_truncated, "truncated"),
        (_header_only, "cannot open"),
        (_garbage, "cannot open"),
        (_zeroed_middle, "truncated or corrupt"),
        (_empty, "cannot open"),
        (_missing, "not found"),
    ],
)
def test_corrupt_video_is_a_clear_error(
    tmp_path: Path, tracker: FaceTracker, make: object, message: str
) -> None:
    video = tmp_path / "bad.mp4"
    make(video)  # type: ignore[operator]
    out = tmp_path / "out" / "points.jsonl"
    out.parent.mkdir()
    out.write_text("previous result\n", encoding="utf-8")
    with pytest.raises(VideoError, match=message) as info:
        track_video(video, out, tracker=tracker)
    assert isinstance(info.value, ValueError)
    # the previous output is untouched and no temporary file is left behind
    assert out.read_text(encoding="utf-8") == "previous result\n"
    assert [p.name for p in out.parent.iterdir()] == ["points.jsonl"]


def test_iter_video_frames_limit() -> None:
    frames = list(iter_video_frames(VIDEO, max_frames=3))
    assert len(frames) == 3 and frames[0].shape == (360, 640, 3)
