"""facesynth.services.control.drivers.virtual.wire: the page's messages, both ways."""

from __future__ import annotations

import json

import msgspec
import pytest

from facesynth.schemas.messages import Frame, Points, PointSet, ServiceStats
from facesynth.services.control.drivers.virtual import wire
from facesynth.services.control.drivers.virtual.geometry import face_geometry


def test_the_page_may_say_hello_and_ping() -> None:
    assert wire.parse_client('{"type": "hello", "frames": false}') == wire.Hello(frames=False)
    assert wire.parse_client('{"type": "hello"}') == wire.Hello(frames=True)
    ping = wire.parse_client('{"type": "ping", "t": 12.5}')
    assert ping == wire.Ping(t=12.5)
    assert json.loads(wire.pong(ping)) == {"type": "pong", "t": 12.5}  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("text", "why"),
    [
        ("", "not a hello or ping"),
        ("not json", "not a hello or ping"),
        ("[1, 2]", "not a hello or ping"),
        ('"hello"', "not a hello or ping"),
        ('{"frames": true}', "not a hello or ping"),
        ('{"type": "move", "jaw": 1000}', "not a hello or ping"),
        ('{"type": "hello", "frames": "yes"}', "not a hello or ping"),
        ('{"type": "hello", "extra": 1}', "not a hello or ping"),
        ('{"type": "ping"}', "not a hello or ping"),
        ('{"type": "ping", "t": 1e999}', "out of range"),
        ('{"type": "ping", "t": "now"}', "not a hello or ping"),
        ('{"type": "hello", "frames": true, ' + '"x": "' + "a" * 2000 + '"}', "limit 1024"),
        ("\udcff", "not a hello or ping"),
    ],
)
def test_anything_else_from_a_page_is_refused(text: str, why: str) -> None:
    with pytest.raises(wire.ClientMessageError, match=why) as info:
        wire.parse_client(text)
    assert "\n" not in str(info.value)


def test_a_face_message_carries_the_geometry() -> None:
    shapes = face_geometry({"jaw": 800.0})
    text = wire.face(12, True, {"jaw": 800.004, "brow_left": 500.0}, shapes, 99)
    data = json.loads(text)
    assert data["type"] == "face" and data["seq"] == 12 and data["t_capture_ns"] == 99
    assert data["controls"] == {"jaw": 800.0, "brow_left": 500.0}
    assert data["shapes"][0]["name"] == "head" and len(data["shapes"]) == len(shapes)
    bars_only = json.loads(wire.face(None, False, {"jaw": 1500.0}, None, None))
    assert bars_only["shapes"] is None and bars_only["seq"] is None


def test_hello_lists_the_controls_for_the_bars() -> None:
    data = json.loads(wire.hello("paper16", [wire.Control("jaw", 1000, 1500, 2000)], False))
    assert data == {
        "type": "hello",
        "profile": "paper16",
        "controls": [{"name": "jaw", "low": 1000, "neutral": 1500, "high": 2000}],
        "face": False,
    }


def _frame(encoding: str, data: bytes) -> Frame:
    return Frame(
        seq=5, t_capture_ns=1, t_media_ns=2, width=4, height=2, encoding=encoding, data=data
    )  # type: ignore[arg-type]


def test_frames_go_as_binary_with_a_header() -> None:
    message = wire.frame(_frame("raw", bytes(range(24))))
    assert message is not None
    header, pixels = wire.read_frame(message)
    assert header == {"seq": 5, "width": 4, "height": 2, "encoding": "raw"}
    assert pixels == bytes(range(24))
    assert wire.frame(_frame("none", b"")) is None  # a tick has nothing to show


def _points(sets: list[PointSet], face: bool = True) -> Points:
    return Points(
        seq=3,
        t_capture_ns=1,
        t_media_ns=1,
        face=face,
        image_width=640,
        image_height=360,
        sets=sets,
    )


def test_points_carry_the_68_points_in_2d() -> None:
    coords = [float(i) for i in range(68 * 3)]
    data = json.loads(wire.points(_points([PointSet(scheme="ibug68", dims=3, coords=coords)])))
    assert data["face"] is True and data["width"] == 640 and len(data["ibug68"]) == 136
    assert data["ibug68"][:4] == [0.0, 1.0, 3.0, 4.0]  # z dropped


@pytest.mark.parametrize(
    "sets",
    [
        [],
        [PointSet(scheme="mesh468", dims=3, coords=[0.0] * 1404)],
        [PointSet(scheme="ibug68", dims=2, coords=[0.0] * 5)],
    ],
)
def test_points_without_a_usable_68_point_set_show_no_face(sets: list[PointSet]) -> None:
    data = json.loads(wire.points(_points(sets)))
    assert data["face"] is False and data["ibug68"] == []


def _stats(service: str, note: str = "", p50: float | None = 1.234) -> ServiceStats:
    return ServiceStats(
        service=service,
        instance="h-1",
        rig="r",
        t_ns=0,
        uptime_s=1.0,
        received=3,
        published=2,
        dropped=1,
        rejected=0,
        rate_hz=29.97,
        latency_p50_ms=p50,
        latency_p99_ms=None,
        note=note,
    )


def test_the_status_board_says_which_services_run() -> None:
    board = wire.StatusBoard(silent_s=3.0)
    board.update(_stats("control"), now_ns=0)
    board.update(_stats("sensor", p50=None), now_ns=2_000_000_000)
    board.update(_stats("points", note="stopped"), now_ns=2_000_000_000)
    rows = board.rows(now_ns=4_000_000_000)
    assert [(r.service, r.status) for r in rows] == [
        ("sensor", "running"),
        ("points", "stopped"),
        ("control", "silent"),  # nothing for 4 s
    ]
    assert rows[2].rate_hz == 30.0 and rows[2].p50_ms == 1.23 and rows[0].p50_ms is None
    assert json.loads(board.message(0))["services"][0]["service"] == "sensor"


def test_the_status_board_shows_each_stage_s_stale_count() -> None:
    board = wire.StatusBoard()
    board.update(msgspec.structs.replace(_stats("features"), stale=5), now_ns=0)
    board.update(_stats("translator"), now_ns=0)
    services = json.loads(board.message(0))["services"]
    assert [
        (row["service"], row["dropped"], row["rejected"], row["stale"]) for row in services
    ] == [
        ("features", 1, 0, 5),
        ("translator", 1, 0, 0),
    ]
