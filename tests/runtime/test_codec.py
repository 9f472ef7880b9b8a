"""runtime.codec: every message type round-trips; every malformed payload gets a clear error."""

from __future__ import annotations

import math
from typing import Any

import msgspec
import pytest

from facesynth.runtime import codec
from facesynth.runtime.codec import MessageError
from facesynth.schemas.messages import (
    Features,
    Frame,
    Points,
    PointSet,
    ScoreSet,
    ServiceStats,
    ServoCommands,
)

NAN = math.nan
INF = math.inf
#: The start of a 4x2 JPEG: start of image, then a baseline frame header (what the codec reads).
TINY_JPEG_HEADER = b"\xff\xd8\xff\xc0\x00\x0b\x08\x00\x02\x00\x04\x01\x01\x11\x00rest"


def _frame(**kw: Any) -> Frame:
    fields: dict[str, Any] = dict(
        seq=3,
        t_capture_ns=10,
        t_media_ns=20,
        width=4,
        height=2,
        encoding="raw",
        data=bytes(range(24)),
        source="cam",
        fps=30.0,
    )
    fields.update(kw)
    return Frame(**fields)


def _points(**kw: Any) -> Points:
    fields: dict[str, Any] = dict(
        seq=3,
        t_capture_ns=10,
        t_media_ns=20,
        face=True,
        confidence=0.9,
        image_width=640,
        image_height=360,
        sets=[PointSet(scheme="ibug68", dims=2, coords=[1.0, 2.0, 3.0, 4.0])],
    )
    fields.update(kw)
    return Points(**fields)


def _features(**kw: Any) -> Features:
    fields: dict[str, Any] = dict(
        seq=3,
        t_capture_ns=10,
        t_media_ns=20,
        face=True,
        neutral_ready=True,
        distances=[0.5, 0.25],
        deltas=[0.0, -0.1],
        named={"brow": 0.2},
    )
    fields.update(kw)
    return Features(**fields)


def _commands(**kw: Any) -> ServoCommands:
    fields: dict[str, Any] = dict(
        seq=3,
        t_capture_ns=10,
        t_media_ns=20,
        face=True,
        profile="paper16",
        positions={"jaw": 1500.0, "left_eyebrow": 1750.5},
    )
    fields.update(kw)
    return ServoCommands(**fields)


def _stats(**kw: Any) -> ServiceStats:
    fields: dict[str, Any] = dict(
        service="features",
        instance="i1",
        rig="default",
        t_ns=5,
        uptime_s=1.5,
        received=10,
        published=9,
        dropped=1,
        rejected=0,
        rate_hz=24.0,
        latency_p50_ms=3.0,
        latency_p99_ms=9.0,
        rss_mb=50.0,
        peak_rss_mb=60.0,
        window=9,
    )
    fields.update(kw)
    return ServiceStats(**fields)


def _roundtrip(message: msgspec.Struct) -> Any:
    return codec.decode(codec.encode(message), type(message))


# --- valid messages ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "message",
    [
        _frame(),
        _frame(encoding="jpeg", data=TINY_JPEG_HEADER),
        _frame(encoding="none", data=b""),
        _points(),
        _points(face=False, sets=[]),
        _points(
            sets=[
                PointSet(scheme="ibug68", dims=2, coords=[1.0, 2.0]),
                PointSet(scheme="mesh468", dims=3, coords=[1.0, 2.0, -3.0]),
            ]
        ),
        _points(scores=[ScoreSet(scheme="blendshapes52", values=[0.0] * 51 + [1.0])]),
        _points(scores=[ScoreSet(scheme="other", values=[-2.5])]),
        _features(),
        _features(face=False, neutral_ready=False, distances=[], deltas=[], named={}),
        _features(neutral_ready=False, deltas=[]),
        _commands(),
        _commands(face=False, positions={}),
        _stats(),
        _stats(latency_p50_ms=None, latency_p99_ms=None),
    ],
    ids=[
        "frame-raw",
        "frame-jpeg",
        "frame-tick",
        "points",
        "points-noface",
        "points-two-sets",
        "points-blendshapes",
        "points-unknown-scores",
        "features",
        "features-noface",
        "features-no-neutral",
        "commands",
        "commands-empty",
        "stats",
        "stats-no-latency",
    ],
)
def test_valid_messages_round_trip(message: msgspec.Struct) -> None:
    assert _roundtrip(message) == message


@pytest.mark.parametrize("wrap", [bytes, bytearray, memoryview], ids=["bytes", "bytearray", "view"])
def test_decode_accepts_any_buffer(wrap: Any) -> None:
    payload = wrap(codec.encode(_points()))
    assert codec.decode(payload, Points) == _points()


def test_encoding_carries_the_tag() -> None:
    raw = msgspec.msgpack.decode(codec.encode(_commands()))
    assert raw["type"] == "servo_commands"


# --- not a message at all ---------------------------------------------------------------------

_GOOD = codec.encode(_points())


@pytest.mark.parametrize(
    ("payload", "detail"),
    [
        (b"", "truncated"),
        (b"\xc1", "invalid"),  # 0xc1 is never used in msgpack
        (b"garbage bytes", "Expected `object`"),
        (_GOOD[: len(_GOOD) // 2], "truncated"),
        (_GOOD[:-1], "truncated"),
        (msgspec.msgpack.encode([1, 2, 3]), "Expected `object`, got `array`"),
    ],
    ids=["empty", "reserved-byte", "garbage", "half", "one-byte-short", "array"],
)
def test_garbage_is_refused(payload: bytes, detail: str) -> None:
    with pytest.raises(MessageError, match="not a valid Points message") as info:
        codec.decode(payload, Points)
    assert detail.lower() in str(info.value).lower()


@pytest.mark.parametrize(
    ("message", "as_cls", "tag"),
    [
        (_points(), Frame, "points"),
        (_frame(), Points, "frame"),
        (_features(), ServoCommands, "features"),
        (_commands(), Features, "servo_commands"),
        (_stats(), Points, "service_stats"),
    ],
    ids=[
        "points-as-frame",
        "frame-as-points",
        "features-as-commands",
        "commands-as-features",
        "stats-as-points",
    ],
)
def test_wrong_tag_is_refused(message: msgspec.Struct, as_cls: type, tag: str) -> None:
    with pytest.raises(MessageError) as info:
        codec.decode(codec.encode(message), as_cls)
    text = str(info.value)
    assert f"not a valid {as_cls.__name__} message" in text
    assert f"Invalid value '{tag}'" in text and "$.type" in text


def _raw_points(**overrides: Any) -> bytes:
    fields: dict[str, Any] = msgspec.to_builtins(_points())
    fields.update(overrides)
    return msgspec.msgpack.encode(fields)


@pytest.mark.parametrize(
    ("overrides", "detail"),
    [
        ({"seq": "3"}, "Expected `int`, got `str` - at `$.seq`"),
        ({"seq": 1.5}, "Expected `int`, got `float` - at `$.seq`"),
        ({"face": 1}, "Expected `bool`, got `int` - at `$.face`"),
        ({"image_width": None}, "Expected `int`, got `None` - at `$.image_width`"),
        ({"sets": {"ibug68": []}}, "Expected `array`, got `object` - at `$.sets`"),
        (
            {"sets": [{"scheme": "ibug68", "dims": 2, "coords": ["1", "2"]}]},
            "Expected `float`, got `str` - at `$.sets[0].coords[0]`",
        ),
        (
            {"sets": [{"scheme": "ibug68", "coords": [1.0, 2.0]}]},
            "missing required field `dims` - at `$.sets[0]`",
        ),
    ],
    ids=["seq-str", "seq-float", "face-int", "width-null", "sets-map", "coord-str", "no-dims"],
)
def test_wrong_field_types_are_refused(overrides: dict[str, Any], detail: str) -> None:
    with pytest.raises(MessageError, match="not a valid Points message") as info:
        codec.decode(_raw_points(**overrides), Points)
    assert detail in str(info.value)


@pytest.mark.parametrize("field", ["type", "source", "encoding"])
def test_a_string_that_is_not_utf8_is_refused(field: str) -> None:
    """msgspec raises UnicodeDecodeError (not a DecodeError) for such strings (found by
    tests/fuzz)."""
    fields = {
        "type": "frame", "seq": 1, "t_capture_ns": 0, "t_media_ns": 0, "width": 1,
        "height": 1, "encoding": "none", "source": "camera",
    }  # fmt: skip
    payload = msgspec.msgpack.encode(fields)
    text = msgspec.msgpack.encode(fields[field])
    broken = payload.replace(text, text[:1] + b"\xe6" + text[2:], 1)
    with pytest.raises(MessageError, match="not a valid Frame message: 'utf-8' codec"):
        codec.decode(broken, Frame)


def test_missing_required_field_is_refused() -> None:
    fields = msgspec.to_builtins(_commands())
    del fields["profile"]
    with pytest.raises(MessageError, match="missing required field `profile`"):
        codec.decode(msgspec.msgpack.encode(fields), ServoCommands)


# --- semantic checks, per message type --------------------------------------------------------


@pytest.mark.parametrize(
    ("frame", "detail"),
    [
        (_frame(seq=-1), "seq is -1: must be >= 0"),
        (_frame(t_capture_ns=-1), "timestamps must be >= 0"),
        (_frame(t_media_ns=-5), "timestamps must be >= 0"),
        (_frame(width=0, data=b""), "frame size 0x2 is out of range"),
        (_frame(height=-2), "frame size 4x-2 is out of range"),
        (
            _frame(width=codec.MAX_FRAME_SIDE + 1, encoding="none", data=b""),
            f"frame size {codec.MAX_FRAME_SIDE + 1}x2 is out of range",
        ),
        (_frame(fps=NAN), "fps is nan"),
        (_frame(fps=INF), "fps is inf"),
        (_frame(fps=1e9), "fps is 1000000000.0"),
        (_frame(data=bytes(23)), "raw frame 4x2 needs 24 bytes, got 23"),
        (_frame(data=bytes(25)), "raw frame 4x2 needs 24 bytes, got 25"),
        (_frame(data=b""), "raw frame 4x2 needs 24 bytes, got 0"),
        (_frame(encoding="jpeg", data=b"\x89PNG\r\n"), "does not start with a JPEG marker"),
        (_frame(encoding="jpeg", data=b""), "does not start with a JPEG marker"),
    ],
    ids=[
        "negative-seq",
        "negative-capture",
        "negative-media",
        "zero-width",
        "negative-height",
        "huge-width",
        "fps-nan",
        "fps-inf",
        "fps-huge",
        "raw-short",
        "raw-long",
        "raw-empty",
        "jpeg-png-bytes",
        "jpeg-empty",
    ],
)
def test_bad_frames(frame: Frame, detail: str) -> None:
    with pytest.raises(MessageError) as info:
        _roundtrip(frame)
    assert detail in str(info.value)


def test_largest_frame_side_is_accepted() -> None:
    frame = _frame(width=codec.MAX_FRAME_SIDE, height=1, encoding="none", data=b"")
    assert _roundtrip(frame).width == codec.MAX_FRAME_SIDE


def _set(coords: list[float], scheme: str = "ibug68", dims: int = 2) -> PointSet:
    return PointSet(scheme=scheme, dims=dims, coords=coords)


@pytest.mark.parametrize(
    ("points", "detail"),
    [
        (_points(seq=-1), "seq is -1"),
        (_points(t_capture_ns=-1), "timestamps must be >= 0"),
        (_points(confidence=NAN), "confidence is nan"),
        (_points(confidence=-INF), "confidence is -inf"),
        (_points(image_width=0), "image size 0x360 is out of range"),
        (_points(image_height=codec.MAX_FRAME_SIDE + 1), "image size 640x8193 is out of range"),
        (_points(face=False), "a 'no face' message must not carry points"),
        (_points(sets=[_set([1.0, 2.0]), _set([3.0, 4.0])]), "'ibug68' appears twice"),
        (_points(sets=[_set([1.0] * 4, dims=4)]), "'ibug68' has dims 4"),
        (_points(sets=[_set([1.0], dims=1)]), "'ibug68' has dims 1"),
        (_points(sets=[_set([1.0, 2.0, 3.0])]), "has 3 values, not a positive multiple of 2"),
        (_points(sets=[_set([])]), "has 0 values, not a positive multiple of 2"),
        (
            _points(sets=[_set([1.0, 2.0, 3.0, 4.0], scheme="mesh468", dims=3)]),
            "'mesh468' has 4 values, not a positive multiple of 3",
        ),
        (_points(sets=[_set([1.0, NAN])]), "a coordinate of 'ibug68' is nan"),
        (_points(sets=[_set([INF, 1.0])]), "a coordinate of 'ibug68' is inf"),
        (_points(sets=[_set([1.0, -INF])]), "a coordinate of 'ibug68' is -inf"),
        (_points(sets=[_set([1.0, 2e6])]), "a coordinate of 'ibug68' is 2000000.0"),
        (
            _points(sets=[_set([1.0, 2.0]), _set([0.0, 0.0, NAN], "mesh468", 3)]),
            "a coordinate of 'mesh468' is nan",
        ),
    ],
    ids=[
        "negative-seq",
        "negative-capture",
        "confidence-nan",
        "confidence-inf",
        "zero-width",
        "huge-height",
        "noface-with-points",
        "duplicate-scheme",
        "dims-4",
        "dims-1",
        "odd-count",
        "empty-coords",
        "mesh-not-multiple-of-3",
        "coord-nan",
        "coord-inf",
        "coord-minus-inf",
        "coord-huge",
        "nan-in-second-set",
    ],
)
def test_bad_points(points: Points, detail: str) -> None:
    with pytest.raises(MessageError) as info:
        _roundtrip(points)
    assert detail in str(info.value)


def _scores(values: list[float], scheme: str = "blendshapes52") -> list[ScoreSet]:
    return [ScoreSet(scheme=scheme, values=values)]


@pytest.mark.parametrize(
    ("points", "detail"),
    [
        (_points(face=False, sets=[], scores=_scores([0.5] * 52)), "must not carry points or"),
        (_points(scores=_scores([0.5] * 52) * 2), "score set 'blendshapes52' appears twice"),
        (_points(scores=_scores([])), "score set 'blendshapes52' is empty"),
        (_points(scores=_scores([0.5] * 51)), "'blendshapes52' has 51 values, not 52"),
        (_points(scores=_scores([0.5] * 53)), "'blendshapes52' has 53 values, not 52"),
        (_points(scores=_scores([0.5] * 51 + [NAN])), "a score of 'blendshapes52' is nan"),
        (_points(scores=_scores([1.5] + [0.5] * 51)), "blendshape '_neutral' is 1.5"),
        (_points(scores=_scores([0.5] * 25 + [-0.1] + [0.5] * 26)), "'jawOpen' is -0.1"),
        (_points(scores=_scores([INF], "other")), "a score of 'other' is inf"),
    ],
    ids=[
        "noface-with-scores",
        "duplicate-scores",
        "empty-scores",
        "51-blendshapes",
        "53-blendshapes",
        "blendshape-nan",
        "blendshape-above-1",
        "blendshape-negative",
        "unknown-scheme-inf",
    ],
)
def test_bad_scores(points: Points, detail: str) -> None:
    with pytest.raises(MessageError) as info:
        _roundtrip(points)
    assert detail in str(info.value)


def test_largest_coordinate_is_accepted() -> None:
    points = _points(sets=[_set([codec.MAX_COORD, -codec.MAX_COORD])])
    assert _roundtrip(points).sets[0].coords == [codec.MAX_COORD, -codec.MAX_COORD]


@pytest.mark.parametrize(
    ("features", "detail"),
    [
        (_features(seq=-7), "seq is -7"),
        (_features(t_media_ns=-1), "timestamps must be >= 0"),
        (_features(deltas=[0.0]), "1 deltas for 2 distances"),
        (_features(deltas=[0.0, 0.0, 0.0]), "3 deltas for 2 distances"),
        (_features(face=False, deltas=[]), "a 'no face' message must not carry features"),
        (_features(face=False, distances=[], deltas=[0.1]), "1 deltas for 0 distances"),
        (_features(distances=[0.5, NAN]), "a distance is nan"),
        (_features(distances=[INF, 0.5]), "a distance is inf"),
        (_features(distances=[1e7, 0.5]), "a distance is 10000000.0"),
        (_features(deltas=[0.0, NAN]), "a delta is nan"),
        (_features(deltas=[-INF, 0.0]), "a delta is -inf"),
        (_features(deltas=[-1e300, 0.0]), "a delta is -1e+300"),
        (_features(named={"brow": NAN}), "feature 'brow' is nan"),
        (_features(named={"brow": 0.1, "jaw": INF, "lid": NAN}), "feature 'jaw' is inf"),
        (_features(raw={"brow": 0.1, "jaw": -2e6}), "feature 'jaw' is -2000000.0"),
    ],
    ids=[
        "negative-seq",
        "negative-media",
        "too-few-deltas",
        "too-many-deltas",
        "noface-with-distances",
        "noface-with-deltas",
        "distance-nan",
        "distance-inf",
        "distance-huge",
        "delta-nan",
        "delta-minus-inf",
        "delta-huge",
        "named-nan",
        "named-first-bad-of-several",
        "raw-huge",
    ],
)
def test_bad_features(features: Features, detail: str) -> None:
    with pytest.raises(MessageError) as info:
        _roundtrip(features)
    assert detail in str(info.value)


@pytest.mark.parametrize(
    ("commands", "detail"),
    [
        (_commands(seq=-1), "seq is -1"),
        (_commands(t_capture_ns=-1), "timestamps must be >= 0"),
        (_commands(profile=""), "servo commands name no profile"),
        (_commands(positions={"jaw": NAN}), "position of 'jaw' is nan"),
        (_commands(positions={"jaw": INF}), "position of 'jaw' is inf"),
        (
            _commands(positions={"jaw": 1500.0, "left_eyebrow": 2e5}),
            "position of 'left_eyebrow' is 200000.0",
        ),
        (_commands(positions={"jaw": -1.0}), "position of 'jaw' is negative (-1.0)"),
    ],
    ids=["negative-seq", "negative-capture", "no-profile", "nan", "inf", "huge", "negative"],
)
def test_bad_servo_commands(commands: ServoCommands, detail: str) -> None:
    with pytest.raises(MessageError) as info:
        _roundtrip(commands)
    assert detail in str(info.value)


@pytest.mark.parametrize(
    ("stats", "detail"),
    [
        (_stats(uptime_s=NAN), "uptime_s is nan"),
        (_stats(rate_hz=INF), "rate_hz is inf"),
        (_stats(rss_mb=NAN), "rss_mb is nan"),
        (_stats(peak_rss_mb=-INF), "peak_rss_mb is -inf"),
    ],
    ids=["uptime-nan", "rate-inf", "rss-nan", "peak-minus-inf"],
)
def test_bad_stats(stats: ServiceStats, detail: str) -> None:
    with pytest.raises(MessageError) as info:
        _roundtrip(stats)
    assert detail in str(info.value)


@pytest.mark.parametrize(
    ("field", "value"),
    [("latency_p50_ms", NAN), ("latency_p99_ms", INF), ("latency_p50_ms", -INF)],
    ids=["p50-nan", "p99-inf", "p50-minus-inf"],
)
def test_stats_latency_must_be_finite(field: str, value: float) -> None:
    # The module promises NaN/inf are refused with a MessageError; latencies are figures too.
    with pytest.raises(MessageError, match=field):
        _roundtrip(_stats(**{field: value}))


@pytest.mark.parametrize("field", ["received", "published", "dropped", "rejected", "window"])
def test_stats_counts_must_not_be_negative(field: str) -> None:
    with pytest.raises(MessageError, match=field):
        _roundtrip(_stats(**{field: -1}))


# --- bounded input: sizes checked before decoding, counts after -------------------------------


def _huge_commands(entries: int) -> bytes:
    """A ServoCommands payload with a positions map of ``entries`` entries (18 MB at 1e6)."""
    positions = {f"servo{i:07d}": 1500.0 for i in range(entries)}
    return codec.encode(_commands(positions=positions))


class _CountingDecoder:
    """Stands in for a type's msgspec decoder: counts the payloads handed to it."""

    def __init__(self, real: msgspec.msgpack.Decoder[Any]) -> None:
        self.real = real
        self.calls = 0

    def decode(self, payload: bytes) -> Any:
        self.calls += 1
        return self.real.decode(payload)


def test_a_million_entry_map_is_refused_before_it_is_built(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    payload = _huge_commands(1_000_000)
    assert len(payload) > 18_000_000
    counting = _CountingDecoder(codec._DECODERS[ServoCommands])
    monkeypatch.setitem(codec._DECODERS, ServoCommands, counting)
    with pytest.raises(MessageError, match="over its limit of 65536 bytes: refused undecoded"):
        codec.decode(payload, ServoCommands)
    assert counting.calls == 0  # never handed to msgspec (building the map takes seconds)
    codec.decode(codec.encode(_commands()), ServoCommands)
    assert counting.calls == 1  # the stand-in sees what the codec decodes


@pytest.mark.parametrize(
    ("cls", "limit"),
    [
        (Frame, 40 * 1024 * 1024),
        (Points, 256 * 1024),
        (Features, 64 * 1024),
        (ServoCommands, 64 * 1024),
        (ServiceStats, 16 * 1024),
    ],
)
def test_each_message_type_has_a_payload_limit(cls: type, limit: int) -> None:
    assert codec.MAX_BYTES[cls] == limit
    with pytest.raises(MessageError, match=f"of {limit + 1} bytes is over its limit of {limit}"):
        codec.decode(b"\x00" * (limit + 1), cls)


def _jpeg_frame(width: int, height: int, **kw: Any) -> Frame:
    import cv2
    import numpy as np

    ok, data = cv2.imencode(".jpg", np.zeros((height, width, 3), np.uint8))
    assert ok
    return _frame(encoding="jpeg", data=data.tobytes(), width=width, height=height, **kw)


def test_a_jpeg_whose_header_matches_the_frame_passes() -> None:
    assert _roundtrip(_jpeg_frame(64, 48)).width == 64


@pytest.mark.parametrize(
    ("frame", "detail"),
    [
        (
            msgspec.structs.replace(_jpeg_frame(64, 48), width=640),
            "jpeg frame is 64x48 by its header, but the frame says 640x48",
        ),
        (
            _frame(encoding="jpeg", data=b"\xff\xd8\xff\xe0\x00\x10", width=4, height=2),
            "jpeg frame: JPEG header cut short",
        ),
        (
            _frame(width=8192, height=8192, encoding="none", data=b""),
            "frame size 8192x8192 is over 12582912 pixels",
        ),
        (
            _frame(width=16000, height=16000, encoding="none", data=b""),
            "frame size 16000x16000 is out of range",
        ),
    ],
    ids=["jpeg-size-lie", "jpeg-header-cut", "too-many-pixels", "side-too-long"],
)
def test_frames_declaring_the_wrong_or_a_huge_size_are_refused_undecoded(
    frame: Frame, detail: str
) -> None:
    with pytest.raises(MessageError) as info:
        _roundtrip(frame)
    assert detail in str(info.value)


def test_a_16000_pixel_jpeg_claim_is_refused_from_its_header() -> None:
    import struct

    sof = b"\xff\xc0" + struct.pack(">HBHHB", 11, 8, 16000, 16000, 1) + b"\x01\x11\x00"
    data = b"\xff\xd8" + sof + b"\x00" * 4_000_000
    frame = _frame(encoding="jpeg", data=data, width=4000, height=3000)
    with pytest.raises(MessageError, match="is 16000x16000 by its header"):
        _roundtrip(frame)


@pytest.mark.parametrize(
    ("message", "cls", "detail"),
    [
        (
            _points(sets=[_set([1.0, 2.0] * 69)]),
            Points,
            "point set 'ibug68' has 69 points: at most 68",
        ),
        (
            _points(sets=[_set([1.0, 2.0, 3.0] * 479, scheme="mesh478", dims=3)]),
            Points,
            "point set 'mesh478' has 479 points: at most 478",
        ),
        (
            _points(sets=[_set([1.0, 2.0] * 1025, scheme="other")]),
            Points,
            "point set 'other' has 1025 points: at most 1024",
        ),
        (
            _points(sets=[_set([1.0, 2.0], scheme=f"s{i}") for i in range(9)]),
            Points,
            "9 point sets and 0 score sets: at most 8 of each",
        ),
        (
            _points(scores=[ScoreSet(scheme="other", values=[0.5] * 257)]),
            Points,
            "score set 'other' has 257 values: at most 256",
        ),
        (
            _features(distances=[0.5] * 69, deltas=[]),
            Features,
            "69 distances and 0 displacement values: at most 68 and 136",
        ),
        (
            _features(named={f"f{i}": 0.0 for i in range(257)}),
            Features,
            "257 named and 0 raw features: at most 256 each",
        ),
        (
            _commands(positions={f"s{i}": 1500.0 for i in range(257)}),
            ServoCommands,
            "257 positions: at most 256 (any profile)",
        ),
        (_commands(sender="x" * 257), ServoCommands, "sender is longer than 256 characters"),
        (_commands(move="y" * 257), ServoCommands, "move is longer than 256 characters"),
        (_commands(sender_seq=-1), ServoCommands, "sender_seq and sent_ns must be >= 0"),
        (_commands(sent_ns=-5), ServoCommands, "sender_seq and sent_ns must be >= 0"),
    ],
    ids=[
        "ibug68-too-many",
        "mesh478-too-many",
        "other-scheme-too-many",
        "too-many-sets",
        "too-many-scores",
        "too-many-distances",
        "too-many-named",
        "too-many-positions",
        "long-sender",
        "long-move",
        "negative-sender-seq",
        "negative-sent",
    ],
)
def test_counts_are_bounded_by_the_schemes(message: Any, cls: type, detail: str) -> None:
    with pytest.raises(MessageError) as info:
        codec.decode(codec.encode(message), cls)
    assert detail in str(info.value)
