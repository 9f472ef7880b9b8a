"""PROTOCOL.md's table, the firmware's C header and protocol.py's table must say the same thing."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from facesynth.services.control.drivers.arduino import protocol as proto

FIRMWARE = Path(__file__).resolve().parents[2] / "firmware"
HEADER = FIRMWARE / "facesynth_servo" / "protocol.h"
MARKDOWN = FIRMWARE / "PROTOCOL.md"
COLUMNS = ["Message", "Code", "Direction", "Payload", "Reply", "Meaning"]


def header_defines(text: str) -> dict[str, int]:
    """``#define FS_NAME <int literal>`` lines of a C header."""
    pattern = re.compile(r"^#define\s+FS_(\w+)\s+(0x[0-9A-Fa-f]+|\d+)U?L?\b", re.MULTILINE)
    return {name: int(value, 0) for name, value in pattern.findall(text)}


def markdown_rows(text: str) -> list[dict[str, str]]:
    """The rows of the one message table (the table whose header is COLUMNS)."""
    lines = text.splitlines()
    for i, line in enumerate(lines):
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if cells == COLUMNS:
            rows = []
            for row in lines[i + 2 :]:
                if not row.startswith("|"):
                    break
                values = [c.strip() for c in row.strip().strip("|").split("|")]
                assert len(values) == len(COLUMNS), row
                rows.append(dict(zip(COLUMNS, values, strict=True)))
            return rows
    raise AssertionError(f"no table with columns {COLUMNS} in {MARKDOWN}")


def markdown_codes(text: str, heading: str) -> dict[str, int]:
    """A bullet list under ``heading``: ``- `N` NAME: ...`` -> {NAME: N}."""
    block = text.split(heading, 1)[1].split("\n\n", 2)[1]
    return {name: int(code, 0) for code, name in re.findall(r"^- `(\w+)` (\w+):", block, re.M)}


@pytest.fixture(scope="module")
def defines() -> dict[str, int]:
    return header_defines(HEADER.read_text())


def test_markdown_table_matches_protocol_py() -> None:
    rows = markdown_rows(MARKDOWN.read_text())
    in_markdown = [
        (r["Message"], r["Code"], r["Direction"], r["Payload"], r["Reply"]) for r in rows
    ]
    in_python = [
        (m.name, f"0x{m.code:02X}", m.direction, m.layout, m.reply or "—") for m in proto.MESSAGES
    ]
    assert in_markdown == in_python


def test_markdown_error_codes_and_flags_match() -> None:
    text = MARKDOWN.read_text()
    assert markdown_codes(text, "NACK error codes:") == {e.name: e.value for e in proto.ErrorCode}
    assert markdown_codes(text, "Flags (ACK and STATUS):") == {
        f.name: f.value for f in proto.Flags if f.name is not None
    }


def test_header_message_codes_match(defines: dict[str, int]) -> None:
    commands = {k[4:]: v for k, v in defines.items() if k.startswith("CMD_")}
    replies = {k[6:]: v for k, v in defines.items() if k.startswith("REPLY_")}
    assert commands == {m.name: m.code for m in proto.MESSAGES if m.direction == "command"}
    assert replies == {m.name: m.code for m in proto.MESSAGES if m.direction == "reply"}


def test_header_payload_sizes_match(defines: dict[str, int]) -> None:
    sizes = {k[5:]: v for k, v in defines.items() if k.startswith("SIZE_")}
    expected = {}
    for m in proto.MESSAGES:
        if m.fields:
            expected[f"{m.name}_ENTRY" if m.repeat else m.name] = m.size
    # The firmware names both STATUS messages' sizes once: only the reply has a payload.
    assert sizes == expected


def test_header_enums_and_constants_match(defines: dict[str, int]) -> None:
    def group(prefix: str) -> dict[str, int]:
        return {k[len(prefix) :]: v for k, v in defines.items() if k.startswith(prefix)}

    assert group("ERR_") == {e.name: e.value for e in proto.ErrorCode}
    assert group("FLAG_") == {f.name: f.value for f in proto.Flags if f.name is not None}
    assert group("OUTPUT_") == {o.name: o.value for o in proto.OutputKind}
    constants = {
        "PROTOCOL_VERSION": proto.PROTOCOL_VERSION,
        "START": proto.START,
        "MAX_PAYLOAD": proto.MAX_PAYLOAD,
        "FRAME_OVERHEAD": proto.FRAME_OVERHEAD,
        "MAX_CHANNELS": proto.MAX_CHANNELS,
        "FRAME_TIMEOUT_MS": proto.FRAME_TIMEOUT_MS,
        "US_ABS_MIN": proto.US_ABS_MIN,
        "US_ABS_MAX": proto.US_ABS_MAX,
        "US_DEFAULT_MIN": proto.US_DEFAULT_MIN,
        "US_DEFAULT_NEUTRAL": proto.US_DEFAULT_NEUTRAL,
        "US_DEFAULT_MAX": proto.US_DEFAULT_MAX,
        "WATCHDOG_DEFAULT_MS": proto.WATCHDOG_DEFAULT_MS,
        "WATCHDOG_MIN_MS": proto.WATCHDOG_MIN_MS,
        "WATCHDOG_MAX_MS": proto.WATCHDOG_MAX_MS,
        "STEP_PERIOD_MS": proto.STEP_PERIOD_MS,
        "CRC_INIT": 0xFFFF,
    }
    assert {k: defines.get(k) for k in constants} == constants


def test_parsers_see_a_difference() -> None:
    """The parsing above is not vacuous: an edited header or table is noticed."""
    text = HEADER.read_text()
    edited = header_defines(
        text.replace("#define FS_CMD_SET_SOME 0x11", "#define FS_CMD_SET_SOME 0x13")
    )
    assert edited["CMD_SET_SOME"] == 0x13 and header_defines(text)["CMD_SET_SOME"] == 0x11
    md = MARKDOWN.read_text()
    rows = markdown_rows(md.replace("| SET_SOME | 0x11 |", "| SET_SOME | 0x12 |"))
    assert [r["Code"] for r in rows if r["Message"] == "SET_SOME"] == ["0x12"]
    assert len(markdown_rows(md)) == len(proto.MESSAGES)
