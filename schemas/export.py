"""Generate the checked-in JSON Schema of every message (``schemas/facesynth.schema.json``).

Run ``python -m schemas.export`` after changing a struct; a test fails while the checked-in file
is stale.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import msgspec

from schemas.messages import ALL_MESSAGES

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


def main() -> int:
    """Write the schema file; with ``--check``, exit 1 when the file is stale instead."""
    text = render_schema()
    if "--check" in sys.argv[1:]:
        current = SCHEMA_PATH.read_text() if SCHEMA_PATH.exists() else ""
        if current != text:
            print(f"{SCHEMA_PATH} is stale: run python -m schemas.export", file=sys.stderr)
            return 1
        return 0
    tmp = SCHEMA_PATH.with_suffix(".tmp")
    tmp.write_text(text)
    tmp.replace(SCHEMA_PATH)
    print(f"wrote {SCHEMA_PATH}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
