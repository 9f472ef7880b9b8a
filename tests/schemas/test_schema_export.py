"""The checked-in JSON Schema is current, and the wire tags never change."""

from __future__ import annotations

import msgspec
import pytest

from facesynth.schemas import export
from facesynth.schemas.messages import ALL_MESSAGES, TAG_FIELD

#: Tags are part of the wire format: changing one breaks every deployed service.
STABLE_TAGS = {
    "Frame": "frame",
    "Points": "points",
    "Features": "features",
    "ServoCommands": "servo_commands",
    "ServiceStats": "service_stats",
    "BabbleSample": "babble_sample",
}


def test_checked_in_schema_is_current() -> None:
    assert export.SCHEMA_PATH.read_text() == export.render_schema(), (
        "schemas/facesynth.schema.json is stale: run python -m facesynth.schemas.export"
    )


def test_check_mode_fails_on_a_stale_file(tmp_path, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    stale = tmp_path / "facesynth.schema.json"
    stale.write_text("{}\n")
    monkeypatch.setattr(export, "SCHEMA_PATH", stale)
    monkeypatch.setattr("sys.argv", ["export", "--check"])
    assert export.main() == 1
    monkeypatch.setattr("sys.argv", ["export"])
    assert export.main() == 0
    assert stale.read_text() == export.render_schema()


@pytest.mark.parametrize("cls", ALL_MESSAGES, ids=lambda c: c.__name__)
def test_tags_are_stable(cls: type[msgspec.Struct]) -> None:
    info = msgspec.inspect.type_info(cls)
    assert isinstance(info, msgspec.inspect.StructType)
    assert info.tag_field == TAG_FIELD
    assert info.tag == STABLE_TAGS[cls.__name__]


def test_every_message_is_in_the_schema() -> None:
    text = export.render_schema()
    for name in STABLE_TAGS:
        assert f'"{name}"' in text
