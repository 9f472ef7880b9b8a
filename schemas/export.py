"""Generate the checked-in JSON Schema of every message (``schemas/facesynth.schema.json``).

Run ``python -m schemas.export`` after changing a struct; a test fails while the checked-in file
is stale.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import msgspec

from facesynth.schemas.messages import ALL_MESSAGES

SCHEMA_PATH = Path(__file__).with_name("facesynth.schema.json")


def render_schema() -> str:
    """Return the JSON Schema of all messages as stable, pretty-printed text."""
    _, components = msgspec.json.schema_components(ALL_MESSAGES)
    document = {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": "facesynth messages",
        "description": "msgpack messages published on facesynth/<rig>/<stage> Zenoh keys.",
        "$defs": components,
    }
    return json.dumps(document, indent=2, sort_keys=True) + "\n"


def message_schema(cls: type[msgspec.Struct]) -> dict[str, Any]:
    """The self-contained JSON Schema of one message (every ``$ref`` inlined).

    Viewers that take one schema per channel (MCAP channels, Foxglove's WebSocket protocol) get
    this: the same definitions as ``facesynth.schema.json``, with no references to resolve.
    """
    _, components = msgspec.json.schema_components((cls,))

    def inline(node: Any) -> Any:
        if isinstance(node, dict):
            ref = node.get("$ref")
            if isinstance(ref, str) and ref.startswith("#/$defs/"):
                return inline(components[ref.removeprefix("#/$defs/")])
            return {key: inline(value) for key, value in node.items()}
        if isinstance(node, list):
            return [inline(item) for item in node]
        return node

    document: dict[str, Any] = {"$schema": "https://json-schema.org/draft/2020-12/schema"}
    document.update(inline(components[cls.__name__]))
    return document


def main() -> int:
    """Write the schema file; with ``--check``, exit 1 when the file is stale instead."""
    text = render_schema()
    if "--check" in sys.argv[1:]:
        current = SCHEMA_PATH.read_text() if SCHEMA_PATH.exists() else ""
        if current != text:
            print(
                f"{SCHEMA_PATH} is stale: run python -m facesynth.schemas.export", file=sys.stderr
            )
            return 1
        return 0
    tmp = SCHEMA_PATH.with_suffix(".tmp")
    tmp.write_text(text)
    tmp.replace(SCHEMA_PATH)
    print(f"wrote {SCHEMA_PATH}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
