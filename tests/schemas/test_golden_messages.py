"""Golden messages: today's encodings keep decoding to the same values (schema evolution).

A new field with a default keeps every golden message decoding; removing, renaming or retyping
a field, a new field without a default or a changed tag fails here, naming the field.
"""

from __future__ import annotations

from typing import Any

import msgspec
import pytest
from golden_messages import FOLDER, GOLDEN, expected, golden_problems

from facesynth.runtime import codec
from facesynth.runtime.frames import decode_frame
from facesynth.schemas.messages import ALL_MESSAGES, TAG_FIELD, Frame, Points, ServoCommands


def _payload(name: str) -> bytes:
    return (FOLDER / f"{name}.msgpack").read_bytes()


def test_every_golden_message_has_its_file() -> None:
    assert {path.stem for path in FOLDER.glob("*.msgpack")} == set(GOLDEN)


def test_every_message_type_has_a_golden_message() -> None:
    assert {cls for cls, _ in GOLDEN.values()} == set(ALL_MESSAGES)


@pytest.mark.parametrize("name", sorted(GOLDEN))
def test_golden_message_decodes_to_its_values(name: str) -> None:
    cls, _ = GOLDEN[name]
    assert golden_problems(_payload(name), cls, expected(name)) == []
    codec.decode(_payload(name), cls)  # and passes today's semantic checks


def test_golden_frames_hold_real_pixels() -> None:
    jpeg = decode_frame(codec.decode(_payload("frame_jpeg"), Frame))
    raw = decode_frame(codec.decode(_payload("frame_raw"), Frame))
    assert jpeg.shape == (9, 16, 3) and raw.shape == (3, 4, 3)


def test_golden_points_hold_every_point_set() -> None:
    points = codec.decode(_payload("points_face"), Points)
    assert [(s.scheme, s.dims, len(s.coords)) for s in points.sets] == [
        ("ibug68", 2, 136),
        ("mesh468", 3, 1404),
        ("iris10", 2, 20),
    ]


# --- the check itself: what an evolved struct may and may not do -------------------------------

COMMANDS: list[tuple[str, Any] | tuple[str, Any, Any]] = [
    ("seq", int),
    ("t_capture_ns", int),
    ("t_media_ns", int),
    ("face", bool),
    ("profile", str),
    ("positions", dict[str, float]),
]


def _commands(
    fields: list[tuple[str, Any] | tuple[str, Any, Any]], tag: str = "servo_commands"
) -> Any:
    return msgspec.defstruct("ServoCommands", fields, tag=tag, tag_field=TAG_FIELD, kw_only=True)


def test_the_unchanged_variant_reads_the_golden_message() -> None:
    """COMMANDS are the fields of the golden ServoCommands, the base of the variants below."""
    golden = msgspec.msgpack.decode(_payload("servo_commands"))
    assert [name for name, *_ in COMMANDS] == [key for key in golden if key != TAG_FIELD]
    same = _commands(COMMANDS)
    assert golden_problems(_payload("servo_commands"), same, expected("servo_commands")) == []


def _without(name: str) -> list[tuple[str, Any] | tuple[str, Any, Any]]:
    return [field for field in COMMANDS if field[0] != name]


@pytest.mark.parametrize(
    ("fields", "tag", "problem"),
    [
        (_without("profile"), "servo_commands", "`$.profile` is no longer a field"),
        (
            [*_without("profile"), ("profile_name", str, "")],
            "servo_commands",
            "`$.profile` is no longer a field",
        ),
        (
            [*_without("positions"), ("positions", dict[str, int])],
            "servo_commands",
            "does not decode as ServoCommands: Expected `int`, got `float`",
        ),
        (
            [*COMMANDS, ("note", str)],
            "servo_commands",
            "Object missing required field `note`",
        ),
        (COMMANDS, "commands", "Invalid value 'servo_commands' - at `$.type`"),
    ],
    ids=["removed", "renamed", "retyped", "new-field-without-default", "tag-changed"],
)
def test_breaking_changes_are_caught(
    fields: list[tuple[str, Any] | tuple[str, Any, Any]], tag: str, problem: str
) -> None:
    problems = golden_problems(
        _payload("servo_commands"), _commands(fields, tag), expected("servo_commands")
    )
    assert any(problem in p for p in problems), problems


def test_a_new_field_with_a_default_is_fine() -> None:
    grown = _commands([*COMMANDS, ("note", str, ""), ("gains", dict[str, float], {})])
    assert golden_problems(_payload("servo_commands"), grown, expected("servo_commands")) == []


def test_a_field_gone_from_a_nested_struct_is_caught() -> None:
    point_set = msgspec.defstruct("PointSet", [("scheme", str), ("coords", list[float])])
    points = msgspec.defstruct(
        "Points",
        [(f.name, f.type, f.default) for f in msgspec.structs.fields(Points) if f.name != "sets"]
        + [("sets", list[point_set], [])],  # type: ignore[valid-type]
        tag="points",
        tag_field=TAG_FIELD,
        kw_only=True,
    )
    problems = golden_problems(_payload("points_face"), points, expected("points_face"))
    assert "`$.sets[0].dims` is no longer a field" in " ".join(problems)


def test_a_changed_value_is_caught() -> None:
    fields = {**expected("servo_commands"), "profile": "paper17"}
    assert golden_problems(_payload("servo_commands"), ServoCommands, fields) == [
        "`$.profile` is 'paper16', expected 'paper17'"
    ]
