"""The MCAP layout: every message stored viewable and rebuilt byte for byte, the rest verbatim."""

from __future__ import annotations

import json
from typing import Any

import jsonschema
import msgspec
import pytest
from mcap.records import Schema
from mcap_protobuf.decoder import DecoderFactory
from messages_sample import messages

from facesynth.app.recording.layout import (
    ANNOTATIONS,
    IMAGE,
    MESSAGE,
    RAW,
    Entry,
    Layout,
    Rebuilder,
    RebuildError,
    key_kind,
)
from facesynth.app.recording.views import IBUG68_OUTLINES
from facesynth.runtime import codec
from facesynth.schemas.messages import Frame, Points, PointSet


def decode_view(entry: Entry) -> Any:
    """A protobuf view decoded with its own schema (as Foxglove does)."""
    assert entry.channel.schema is not None
    schema = entry.channel.schema
    record = Schema(id=1, name=schema.name, encoding=schema.encoding, data=schema.data)
    decoder = DecoderFactory().decoder_for(entry.channel.message_encoding, record)
    assert decoder is not None
    return decoder(entry.data)


def rebuild(entries: list[Entry], rebuilder: Rebuilder) -> list[bytes]:
    out = []
    for entry in entries:
        data = decode_view(entry).data if entry.channel.role == IMAGE else entry.data
        payload = rebuilder.feed(entry.channel.key, entry.channel.role, data, entry.sequence)
        if payload is not None:
            out.append(payload)
    return out


SAMPLES = messages(3)


@pytest.mark.parametrize(
    ("key", "payload"),
    SAMPLES,
    ids=[f"{k.split('/', 2)[2]}-{i}" for i, (k, _) in enumerate(SAMPLES)],
)
def test_every_message_comes_back_byte_for_byte(key: str, payload: bytes) -> None:
    entries = Layout().entries(key, payload, 123, 7)
    assert all(entry.channel.role != RAW for entry in entries)
    assert rebuild(entries, Rebuilder()) == [payload]


@pytest.mark.parametrize(("key", "payload"), SAMPLES)
def test_stored_json_matches_the_message_schema(key: str, payload: bytes) -> None:
    (entry,) = [e for e in Layout().entries(key, payload, 1, 0) if e.channel.role == MESSAGE]
    assert entry.channel.topic == "/" + key and entry.channel.message_encoding == "json"
    assert entry.channel.schema is not None and entry.channel.schema.encoding == "jsonschema"
    schema = json.loads(entry.channel.schema.data)
    assert "$ref" not in entry.channel.schema.data.decode(), "one self-contained schema per channel"
    jsonschema.validate(json.loads(entry.data), schema)


def test_frames_carry_their_pixels_as_foxglove_images() -> None:
    jpeg_key, jpeg_payload = SAMPLES[0]
    entries = Layout().entries(jpeg_key, jpeg_payload, 1, 0)
    image = next(e for e in entries if e.channel.role == IMAGE)
    assert (
        image.channel.schema is not None and image.channel.schema.name == "foxglove.CompressedImage"
    )
    view = decode_view(image)
    frame = codec.decode(jpeg_payload, Frame)
    assert (view.format, bytes(view.data)) == ("jpeg", frame.data)
    assert view.timestamp.seconds * 10**9 + view.timestamp.nanos == frame.t_capture_ns
    stored = json.loads(next(e for e in entries if e.channel.role == MESSAGE).data)
    assert stored["data"] == "", "pixels live on the image channel only"
    raw = decode_view(
        next(e for e in Layout().entries(*SAMPLES[1], 1, 0) if e.channel.role == IMAGE)
    )
    assert (raw.encoding, raw.width, raw.height, raw.step) == ("bgr8", 4, 2, 12)
    assert [e.channel.role for e in Layout().entries(*SAMPLES[2], 1, 0)] == [MESSAGE]


def test_landmarks_are_drawn_over_the_image() -> None:
    key, payload = SAMPLES[3]
    annotations = next(
        e for e in Layout().entries(key, payload, 1, 0) if e.channel.role == ANNOTATIONS
    )
    view = decode_view(annotations)
    points = codec.decode(payload, Points)
    assert len(view.points) == len(IBUG68_OUTLINES) + 1  # face outlines + iris dots
    jaw = view.points[0]
    ibug = points.sets[0].coords
    assert [(p.x, p.y) for p in jaw.points] == [(ibug[2 * i], ibug[2 * i + 1]) for i in range(17)]
    assert jaw.timestamp.seconds * 10**9 + jaw.timestamp.nanos == points.t_capture_ns
    no_face = decode_view(
        next(e for e in Layout().entries(*SAMPLES[4], 1, 0) if e.channel.role == ANNOTATIONS)
    )
    assert len(no_face.points) == 0


def test_a_stream_with_only_the_mesh_shows_it_as_dots() -> None:
    mesh = [float(v) for i in range(478) for v in (i, 2 * i, 0.5)]
    points = Points(
        seq=1,
        t_capture_ns=5,
        t_media_ns=5,
        face=True,
        confidence=1.0,
        image_width=640,
        image_height=480,
        sets=[PointSet(scheme="mesh478", dims=3, coords=mesh)],
    )
    key = "facesynth/default/points"
    entry = next(
        e
        for e in Layout().entries(key, codec.encode(points), 1, 0)
        if e.channel.role == ANNOTATIONS
    )
    (dots,) = decode_view(entry).points
    assert len(dots.points) == 478
    assert (dots.points[3].x, dots.points[3].y) == (3.0, 6.0)


def _unknown_field(payload: bytes) -> bytes:
    data = msgspec.msgpack.decode(payload)
    data["added_in_a_newer_version"] = [1, 2]
    return msgspec.msgpack.encode(data)


def _int_confidence(payload: bytes) -> bytes:
    data = msgspec.msgpack.decode(payload)
    data["confidence"] = 1
    return msgspec.msgpack.encode(data)


NAN_POINTS = codec.encode(
    Points(
        seq=1,
        t_capture_ns=1,
        t_media_ns=1,
        face=True,
        image_width=9,
        image_height=9,
        sets=[PointSet(scheme="ibug68", dims=2, coords=[float("nan"), 1.0])],
    )
)
TICK_WITH_BYTES = codec.encode(
    Frame(seq=1, t_capture_ns=1, t_media_ns=1, width=4, height=4, encoding="none", data=b"x")
)

KEPT_VERBATIM = [
    ("not msgpack", "facesynth/default/points", b"\xc1garbage"),
    ("wrong type", "facesynth/default/features", SAMPLES[6][1]),
    ("NaN coordinate", "facesynth/default/points", NAN_POINTS),
    ("unknown field", "facesynth/default/servo_state", _unknown_field(SAMPLES[7][1])),
    ("int for a float", "facesynth/default/points", _int_confidence(SAMPLES[3][1])),
    ("tick with bytes", "facesynth/default/input", TICK_WITH_BYTES),
    ("unknown key", "facesynth/default/something_else", b"\x01\x02"),
]


@pytest.mark.parametrize(
    ("key", "payload"), [c[1:] for c in KEPT_VERBATIM], ids=[c[0] for c in KEPT_VERBATIM]
)
def test_what_would_not_come_back_exactly_is_kept_verbatim(key: str, payload: bytes) -> None:
    layout = Layout()
    (entry,) = layout.entries(key, payload, 5, 1)
    assert entry.channel.role == RAW and entry.channel.topic == f"/{key}/raw"
    assert entry.channel.message_encoding == "msgpack" and entry.channel.schema is None
    assert layout.raw[key] == 1
    assert Rebuilder().feed(key, RAW, entry.data, 1) == payload


def test_a_frame_and_its_pixels_pair_in_either_order() -> None:
    key, payload = SAMPLES[0]
    entries = Layout().entries(key, payload, 1, 9)
    assert rebuild(list(reversed(entries)), Rebuilder()) == [payload]


def test_unpaired_halves_are_bounded() -> None:
    rebuilder = Rebuilder(max_pending=4)
    key, payload = SAMPLES[0]
    for sequence in range(10):
        meta = next(
            e for e in Layout().entries(key, payload, 1, sequence) if e.channel.role == MESSAGE
        )
        assert rebuilder.feed(key, MESSAGE, meta.data, sequence) is None
    assert rebuilder.orphans == 6


def test_a_damaged_stored_message_is_a_clear_error() -> None:
    with pytest.raises(RebuildError, match="not a valid ServoCommands"):
        Rebuilder().feed(
            "facesynth/default/servo_state", MESSAGE, b'{"type": "servo_commands", "seq": "x"}', 0
        )


COMMANDS = dict(SAMPLES)["facesynth/default/servo_commands"]
FEATURES = dict(SAMPLES)["facesynth/default/features"]
#: (key, payload, kind): a robot's commands and state are typed as their stage's; keys that
#: only look like a robot's stay untyped (kept verbatim, as any key facesynth does not define).
ROBOT_KEYS = [
    ("facesynth/default/servo_commands/head1", COMMANDS, "servo_commands"),
    ("facesynth/lab/servo_state/r.07", COMMANDS, "servo_state"),
    ("facesynth/default/servo_commands/a/b", COMMANDS, None),  # five parts
    ("facesynth/default/servo_commands/", COMMANDS, None),  # no robot
    ("facesynth/default/servo_state/a b", COMMANDS, None),  # not a name
    ("facesynth/default/features/x", FEATURES, None),  # one feed for every robot
    ("facesynth/default/babble/x", COMMANDS, None),
    ("other/default/servo_commands/head1", COMMANDS, None),
]


def test_a_robots_commands_and_state_are_typed_like_their_stage_and_nothing_else() -> None:
    for key, payload, kind in ROBOT_KEYS:
        assert key_kind(key) == kind, key
        layout = Layout()
        entries = layout.entries(key, payload, 5, 1)
        (entry,) = entries
        if kind is None:
            assert entry.channel.role == RAW and layout.raw[key] == 1, key
            continue
        assert entry.channel.role == MESSAGE and entry.channel.topic == "/" + key
        assert entry.channel.schema is not None
        assert entry.channel.schema.name == "facesynth.ServoCommands"
        assert json.loads(entry.data)["positions"]["jaw"] == 1500.125
        assert not layout.raw
        assert rebuild(entries, Rebuilder()) == [payload]
