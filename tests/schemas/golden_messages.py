"""Golden messages: today's encodings of every message type, which must keep decoding.

``tests/fixtures/messages/<name>.msgpack`` holds :data:`GOLDEN` ``[name]`` as encoded by
``facesynth.runtime.codec.encode`` when the file was made; ``frame.jpg`` is the JPEG payload of
``frame_jpeg`` (the sample video's first frame scaled to 16x9, quality 80). The expected values
below are plain data (not structs), so that a field removed from a struct still lets this module
load and the test say which field went.

Made with ``python tests/schemas/golden_messages.py``, which writes only the files that do not
exist yet. Never rewrite an existing fixture: it stands for the senders already deployed. To
cover a new message type or a new field, add a new name here and run the script.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import msgspec

from facesynth.schemas.messages import (
    BabbleSample,
    Features,
    Frame,
    Points,
    ServiceStats,
    ServoCommands,
)

FOLDER = Path(__file__).resolve().parents[1] / "fixtures" / "messages"
JPEG = FOLDER / "frame.jpg"

# Landmarks laid out on a grid in a 640x360 frame: plain arithmetic, exact on every platform.
IBUG68 = [c for i in range(68) for c in (200.0 + (i % 17) * 12.5, 100.0 + (i // 17) * 25.25)]
MESH468 = [
    c
    for i in range(468)
    for c in (250.0 + (i % 26) * 5.5, 90.0 + (i // 26) * 10.75, -20.0 + (i % 9) * 2.5)
]
IRIS10 = [c for i in range(10) for c in (280.0 + (i // 5) * 80 + (i % 5), 150.5 + (i % 5) * 0.75)]
NAMED = {
    "jaw_open": 0.25,
    "gaze_right_x": -0.125,
    "gaze_left_x": -0.1,
    "brow_raise_inner_right": 0.5,
    "lip_corner_pull_left": 0.875,
    "head_yaw": 3.5,
}

#: name -> (message type, its fields as plain data), one fixture file each.
GOLDEN: dict[str, tuple[type[msgspec.Struct], dict[str, Any]]] = {
    "frame_jpeg": (
        Frame,
        {
            "seq": 42,
            "t_capture_ns": 1_717_000_000_123_456_789,
            "t_media_ns": 1_751_750_000,
            "width": 16,
            "height": 9,
            "encoding": "jpeg",
            "data": b"",  # frame.jpg, filled in by expected()
            "source": "WolfgangLanger_Pexels.mp4",
            "fps": 23.976,
        },
    ),
    "frame_raw": (
        Frame,
        {
            "seq": 43,
            "t_capture_ns": 1_717_000_000_165_000_000,
            "t_media_ns": 1_793_458_333,
            "width": 4,
            "height": 3,
            "encoding": "raw",
            "data": bytes((i * 7) % 256 for i in range(4 * 3 * 3)),
            "source": "camera:0",
            "fps": 30.0,
        },
    ),
    "points_face": (
        Points,
        {
            "seq": 42,
            "t_capture_ns": 1_717_000_000_123_456_789,
            "t_media_ns": 1_751_750_000,
            "face": True,
            "confidence": 0.9375,
            "image_width": 640,
            "image_height": 360,
            "sets": [
                {"scheme": "ibug68", "dims": 2, "coords": IBUG68},
                {"scheme": "mesh468", "dims": 3, "coords": MESH468},
                {"scheme": "iris10", "dims": 2, "coords": IRIS10},
            ],
            "source": "tracker",
        },
    ),
    "points_no_face": (
        Points,
        {
            "seq": 44,
            "t_capture_ns": 1_717_000_000_207_000_000,
            "t_media_ns": 1_835_166_667,
            "face": False,
            "confidence": 0.125,
            "image_width": 640,
            "image_height": 360,
            "sets": [],
            "source": "tracker",
        },
    ),
    "features": (
        Features,
        {
            "seq": 42,
            "t_capture_ns": 1_717_000_000_123_456_789,
            "t_media_ns": 1_751_750_000,
            "face": True,
            "neutral_ready": True,
            "scheme": "ibug68",
            "distances": [0.5 + i / 64 for i in range(68)],
            "deltas": [(i % 7 - 3) / 128 for i in range(68)],
            "named": NAMED,
            "raw": {name: value * 0.5 for name, value in NAMED.items()},
            "displacements": [(i % 5 - 2) / 256 for i in range(136)],
        },
    ),
    "servo_commands": (
        ServoCommands,
        {
            "seq": 42,
            "t_capture_ns": 1_717_000_000_123_456_789,
            "t_media_ns": 1_751_750_000,
            "face": True,
            "profile": "paper16",
            "positions": {"jaw": 1612.5, "right_eyebrow": 1480.25, "right_eye_x": 1375.0},
        },
    ),
    # Added with the freshness fields (issue 12): a translator's command that can be aged.
    "servo_commands_sent": (
        ServoCommands,
        {
            "seq": 43,
            "t_capture_ns": 1_717_000_000_165_000_000,
            "t_media_ns": 1_793_458_333,
            "face": True,
            "profile": "paper16",
            "positions": {"jaw": 1625.0, "right_eyebrow": 1482.5, "right_eye_x": 1380.0},
            "sender": "tracker-host-4242",
            "sender_seq": 44,
            "sent_ns": 1_717_000_000_171_250_000,
            "sender_host": "tracker-host",
            "move": "command",
        },
    ),
    # ... and a control interface's own move on …/servo_state (returning to neutral).
    "servo_state_own_move": (
        ServoCommands,
        {
            "seq": 43,
            "t_capture_ns": 1_717_000_000_165_000_000,
            "t_media_ns": 1_793_458_333,
            "face": False,
            "profile": "paper16",
            "positions": {"jaw": 1560.0, "right_eyebrow": 1500.0, "right_eye_x": 1500.0},
            "sender": "board-77",
            "sender_seq": 12,
            "sent_ns": 1_717_000_000_800_000_000,
            "sender_host": "board",
            "move": "return",
        },
    ),
    "service_stats": (
        ServiceStats,
        {
            "service": "points",
            "instance": "points-1a2b3c",
            "rig": "default",
            "t_ns": 1_717_000_012_000_000_000,
            "uptime_s": 12.5,
            "received": 300,
            "published": 298,
            "dropped": 1,
            "rejected": 1,
            "rate_hz": 23.9,
            "latency_p50_ms": 8.25,
            "latency_p99_ms": 14.5,
            "rss_mb": 182.5,
            "peak_rss_mb": 190.0,
            "window": 300,
            "note": "backend litert",
        },
    ),
    "service_stats_idle": (
        ServiceStats,
        {
            "service": "control",
            "instance": "control-9f8e7d",
            "rig": "lab",
            "t_ns": 1_717_000_001_000_000_000,
            "uptime_s": 1.0,
            "received": 0,
            "published": 0,
            "dropped": 0,
            "rejected": 0,
            "rate_hz": 0.0,
            "latency_p50_ms": None,
            "latency_p99_ms": None,
            "rss_mb": 41.0,
            "peak_rss_mb": 41.0,
            "window": 0,
            "note": "",
        },
    ),
    "babble_sample": (
        BabbleSample,
        {
            "seq": 17,
            "t_capture_ns": 1_717_000_003_000_000_000,
            "t_media_ns": 42_500_000_000,
            "profile": "paper16",
            "kind": "random",
            "commanded": {"jaw": 1612.5, "right_eyebrow": 1375.25},
            "reported": {"jaw": 1612.5, "right_eyebrow": 1375.25},
            "features": {"jaw_open": 0.25, "brow_raise_inner_right": -0.125},
            "spread": {"jaw_open": 0.0078125, "brow_raise_inner_right": 0.00390625},
            "frames": 5,
            "settled": True,
            "seed": 7,
        },
    ),
}


def expected(name: str) -> dict[str, Any]:
    """The fields of golden message ``name`` as plain data (the JPEG read from its file)."""
    fields = GOLDEN[name][1]
    if name == "frame_jpeg":
        return {**fields, "data": JPEG.read_bytes()}
    return fields


def golden_problems(payload: bytes, cls: Any, fields: dict[str, Any]) -> list[str]:
    """Why today's ``cls`` no longer reads a golden ``payload`` as ``fields`` (empty: it does).

    A field the payload carries but ``cls`` (or a struct inside it) no longer has was removed
    or renamed: deployed senders still send it, so that is a problem even though msgspec would
    skip it. A field ``cls`` has gained is fine when it has a default (older senders omit it).
    """
    problems = [
        f"{where} is no longer a field (removed or renamed; deployed senders still send it)"
        for where in _gone_fields(msgspec.msgpack.decode(payload), msgspec.inspect.type_info(cls))
    ]
    try:
        decoded = msgspec.msgpack.decode(payload, type=cls)
    except (msgspec.DecodeError, msgspec.ValidationError) as exc:
        return [*problems, f"does not decode as {cls.__name__}: {exc}"]
    actual = msgspec.to_builtins(decoded, builtin_types=(bytes,))
    problems.extend(_differences(fields, actual, msgspec.inspect.type_info(cls), "$"))
    return problems


def _gone_fields(raw: Any, info: msgspec.inspect.Type, path: str = "$") -> list[str]:
    """Paths of the map keys in ``raw`` that the type ``info`` has no field for."""
    if isinstance(info, msgspec.inspect.UnionType):
        structs = [t for t in info.types if isinstance(t, msgspec.inspect.StructType)]
        return _gone_fields(raw, structs[0], path) if structs and isinstance(raw, dict) else []
    if isinstance(info, msgspec.inspect.StructType) and isinstance(raw, dict):
        by_name = {f.encode_name: f.type for f in info.fields}
        gone = [f"`{path}.{key}`" for key in raw if key not in by_name and key != info.tag_field]
        for key, value in raw.items():
            if key in by_name:
                gone.extend(_gone_fields(value, by_name[key], f"{path}.{key}"))
        return gone
    if isinstance(info, msgspec.inspect.ListType) and isinstance(raw, list):
        return [
            problem
            for i, item in enumerate(raw)
            for problem in _gone_fields(item, info.item_type, f"{path}[{i}]")
        ]
    return []


def _differences(expected: Any, actual: Any, info: msgspec.inspect.Type, path: str) -> list[str]:
    """Where ``actual`` differs from ``expected`` (plain data of type ``info``).

    A struct in ``actual`` may have more fields than ``expected``: fields added since.
    """
    if isinstance(info, msgspec.inspect.StructType) and isinstance(actual, dict):
        types = {f.encode_name: f.type for f in info.fields}
        problems = []
        for key, value in expected.items():
            if key not in actual:
                problems.append(f"`{path}.{key}` is missing")
            else:
                problems.extend(_differences(value, actual[key], types[key], f"{path}.{key}"))
        return problems
    if (
        isinstance(info, msgspec.inspect.ListType)
        and isinstance(actual, list)
        and len(actual) == len(expected)
    ):
        return [
            problem
            for i, (e, a) in enumerate(zip(expected, actual, strict=True))
            for problem in _differences(e, a, info.item_type, f"{path}[{i}]")
        ]
    if expected != actual or type(expected) is not type(actual):
        return [f"`{path}` is {actual!r:.60}, expected {expected!r:.60}"]
    return []


def write_missing(folder: Path = FOLDER) -> list[Path]:
    """Write the fixtures that do not exist yet (never an existing one); returns those written."""
    from facesynth.runtime import codec

    folder.mkdir(parents=True, exist_ok=True)
    if not JPEG.exists():
        import cv2

        from facesynth.app.data import sample_video

        capture = cv2.VideoCapture(str(sample_video()))
        _, image = capture.read()
        capture.release()
        small = cv2.resize(image, (16, 9), interpolation=cv2.INTER_AREA)
        JPEG.write_bytes(cv2.imencode(".jpg", small, [cv2.IMWRITE_JPEG_QUALITY, 80])[1].tobytes())
    written = []
    for name, (cls, _) in GOLDEN.items():
        path = folder / f"{name}.msgpack"
        if not path.exists():
            path.write_bytes(codec.encode(msgspec.convert(expected(name), cls)))
            written.append(path)
    return written


if __name__ == "__main__":
    for path in write_missing():
        print(f"wrote {path}", file=sys.stderr)
