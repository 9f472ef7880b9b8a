"""facesynth.services.points.backends: OpenFace CSV and track-file replays, one Points per Frame."""

from __future__ import annotations

import json
import re
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from facesynth.runtime import codec
from facesynth.schemas.messages import Frame, Points
from facesynth.services.points.backends import BackendError
from facesynth.services.points.backends.openface import OpenFaceConfig, OpenFaceReplay
from facesynth.services.points.backends.track import TrackFileConfig, TrackReplay
from facesynth.services.points.openface_csv import OpenFaceError, load_openface_csv


def _real_csv() -> Path:
    return Path(str(resources.files("facesynth.app.data") / "OpenFace_Test.csv"))


def _frame(seq: int) -> Frame:
    return Frame(
        seq=seq,
        t_capture_ns=1_000 + seq,
        t_media_ns=40_000_000 * seq,
        width=640,
        height=360,
        encoding="none",
    )


def _valid(points: Points) -> Points:
    return codec.decode(codec.encode(points), Points)


# --- OpenFaceReplay ---------------------------------------------------------------------------


def test_openface_replay_answers_frame_n_with_row_n() -> None:
    replay = OpenFaceReplay(OpenFaceConfig(csv=str(_real_csv())))
    rows = load_openface_csv(_real_csv())
    assert replay.frame_count() == 100
    assert replay.needs_pixels() is False
    for seq in (0, 1, 57, 99):
        points = _valid(replay.process(_frame(seq)))
        assert points.face is True
        assert (points.seq, points.t_capture_ns, points.t_media_ns) == (
            seq,
            1_000 + seq,
            40_000_000 * seq,
        )
        assert (points.image_width, points.image_height) == (640, 360)
        assert points.source == "openface"
        assert points.confidence == rows[seq].confidence
        (ibug,) = points.sets
        assert (ibug.scheme, ibug.dims) == ("ibug68", 2)
        np.testing.assert_array_equal(np.reshape(ibug.coords, (68, 2)), rows[seq].points)


@pytest.mark.parametrize(
    ("loop", "seq", "row"),
    [(False, 100, None), (False, 5000, None), (True, 100, 0), (True, 101, 1), (True, 257, 57)],
    ids=["past-end", "far-past-end", "loop-100", "loop-101", "loop-257"],
)
def test_openface_replay_past_the_end(loop: bool, seq: int, row: int | None) -> None:
    replay = OpenFaceReplay(OpenFaceConfig(csv=str(_real_csv()), loop=loop))
    points = _valid(replay.process(_frame(seq)))
    assert points.seq == seq
    if row is None:
        assert points.face is False and points.sets == []
    else:
        expected = replay.process(_frame(row)).sets[0].coords
        assert points.face is True and points.sets[0].coords == expected


def test_openface_replay_failed_rows_are_no_face(tmp_path: Path) -> None:
    header, *data = _real_csv().read_text().splitlines()
    success = [name.strip() for name in header.split(",")].index("success")
    fields = data[1].split(",")
    fields[success] = " 0"
    path = tmp_path / "of.csv"
    path.write_text("\n".join([header, data[0], ",".join(fields), data[2]]) + "\n")
    replay = OpenFaceReplay(OpenFaceConfig(csv=str(path)))
    assert [replay.process(_frame(i)).face for i in range(4)] == [True, False, True, False]
    lost = _valid(replay.process(_frame(1)))
    assert lost.sets == [] and lost.confidence == replay.rows[1].confidence > 0


def test_openface_replay_bad_file(tmp_path: Path) -> None:
    path = tmp_path / "of.csv"
    path.write_text("")
    with pytest.raises(OpenFaceError, match="the file is empty"):
        OpenFaceReplay(OpenFaceConfig(csv=str(path)))


# --- TrackReplay ------------------------------------------------------------------------------

RNG = np.random.default_rng(7)
IBUG = RNG.uniform(0, 600, (68, 2)).round(3)
MESH = RNG.uniform(0, 600, (468, 3)).round(3)
IRIS = RNG.uniform(0, 600, (10, 2)).round(3)


def _line(frame: int, face: bool = True, **kw: Any) -> str:
    data: dict[str, Any] = {"frame": frame, "face": face}
    if face:
        data.update(ibug68=IBUG.tolist(), mesh=MESH.tolist(), iris=IRIS.tolist(), presence=0.93)
    data.update(kw)
    return json.dumps({k: v for k, v in data.items() if v is not None})


def _track(tmp_path: Path, *lines: str) -> Path:
    path = tmp_path / "face.track.jsonl"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_track_replay(tmp_path: Path) -> None:
    path = _track(
        tmp_path, _line(0), _line(1, False, presence=0.2), "", _line(2, mesh=None, iris=None)
    )
    replay = TrackReplay(TrackFileConfig(path=str(path)))
    assert replay.frame_count() == 3  # the blank line is not a frame
    first = _valid(replay.process(_frame(0)))
    assert first.face is True and first.confidence == 0.93 and first.source == "track"
    assert [(s.scheme, s.dims) for s in first.sets] == [
        ("ibug68", 2),
        ("mesh468", 3),
        ("iris10", 2),
    ]
    np.testing.assert_array_equal(np.reshape(first.sets[0].coords, (68, 2)), IBUG)
    np.testing.assert_array_equal(np.reshape(first.sets[1].coords, (468, 3)), MESH)
    np.testing.assert_array_equal(np.reshape(first.sets[2].coords, (10, 2)), IRIS)
    lost = _valid(replay.process(_frame(1)))
    assert lost.face is False and lost.sets == [] and lost.confidence == 0.2
    only_ibug = _valid(replay.process(_frame(2)))
    assert [s.scheme for s in only_ibug.sets] == ["ibug68"]
    assert _valid(replay.process(_frame(3))).face is False  # past the end
    assert (
        TrackReplay(TrackFileConfig(path=str(path), loop=True)).process(_frame(3)).sets
        == first.sets
    )


def test_track_replay_3d_ibug(tmp_path: Path) -> None:
    ibug3 = np.column_stack([IBUG, np.arange(68.0)])
    replay = TrackReplay(
        TrackFileConfig(path=str(_track(tmp_path, _line(0, ibug68=ibug3.tolist()))))
    )
    (ibug, *_) = replay.process(_frame(0)).sets
    assert ibug.dims == 3 and ibug.coords[:3] == [*IBUG[0], 0.0]


def _broken(count: int, dims: int = 2) -> list[list[float]]:
    return [[1.0] * dims for _ in range(count)]


@pytest.mark.parametrize(
    ("lines", "detail"),
    [
        ([_line(0), "{not json"], ":2: JSON is malformed"),
        ([_line(0), _line(1), '{"frame": 2, "face": true'], ":3: Input data was truncated"),
        (["[1, 2]"], ":1: Expected `object`, got `array`"),
        (['{"face": false}'], ":1: Object missing required field `frame`"),
        (['{"frame": 0, "face": "yes"}'], ":1: Expected `bool`, got `str` - at `$.face`"),
        ([_line(0, ibug68=_broken(67))], ":1: ibug68 must be 68 finite [x, y] points"),
        ([_line(0, ibug68=_broken(69))], ":1: ibug68 must be 68 finite [x, y] points"),
        ([_line(0, ibug68=_broken(68, 4))], ":1: ibug68 must be 68 finite [x, y] points"),
        ([_line(0, ibug68=[1.0] * 136)], "Expected `array`, got `float` - at `$.ibug68[0]`"),
        ([_line(0, mesh=_broken(467, 3))], ":1: mesh must be 468 finite [x, y] points"),
        ([_line(0, iris=_broken(5))], ":1: iris must be 10 finite [x, y] points"),
        ([_line(0, iris=[[1.0, 2.0], [3.0]] * 5)], ":1: iris must be 10 finite [x, y] points"),
        ([_line(0), _line(1, ibug68=None)], ":2: a face line needs ibug68 points"),
        (
            [_line(0, ibug68=[[1e999, 0.0], *_broken(67)])],
            ":1: Number out of range - at `$.ibug68[0][0]`",
        ),
        (
            [_line(0, mesh=[[0.0, 0.0, -1e999], *_broken(467, 3)])],
            ":1: Number out of range - at `$.mesh[0][2]`",
        ),
        ([_line(0, presence=1e999)], ":1: Number out of range - at `$.presence`"),
        (["", "  "], ": no frames"),
    ],
    ids=[
        "bad-json",
        "truncated-json",
        "not-an-object",
        "no-frame-field",
        "face-not-bool",
        "ibug-67",
        "ibug-69",
        "ibug-4d",
        "ibug-flat",
        "mesh-467",
        "iris-5",
        "iris-ragged",
        "face-without-ibug",
        "ibug-infinite",
        "mesh-infinite",
        "presence-infinite",
        "empty",
    ],
)
def test_malformed_track_files(tmp_path: Path, lines: list[str], detail: str) -> None:
    # json.dumps writes 1e999 as Infinity; put the literal back as a JSON number.
    path = _track(tmp_path, *(line.replace("Infinity", "1e999") for line in lines))
    with pytest.raises(BackendError) as info:
        TrackReplay(TrackFileConfig(path=str(path)))
    message = str(info.value)
    assert message.startswith(str(path))
    assert detail in message


def test_missing_track_file(tmp_path: Path) -> None:
    path = tmp_path / "gone.jsonl"
    with pytest.raises(BackendError, match=f"cannot read {re.escape(str(path))}"):
        TrackReplay(TrackFileConfig(path=str(path)))
