"""services.control.drivers.record: the record driver, and driver configs through the registry."""

from __future__ import annotations

import json
import logging
import re
import time
from pathlib import Path

import pytest

from facesynth.runtime.plugins import PluginError
from facesynth.runtime.profiles import load_profile
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.base import DriverConfigError, DriverError
from facesynth.services.control.drivers.record import (
    RecordConfig,
    RecordDriver,
    RecordError,
    RecordLine,
    earlier_sessions,
    read_record,
    read_sessions,
    record_summary,
)
from facesynth.services.control.drivers.registry import DRIVERS

KEYS = {"seq", "frame", "t_capture_ns", "t_sent_ns", "face", "servos"}
SESSION_KEYS = {"started_ns", "profile", "host", "pid"}


async def test_lines_have_exactly_the_documented_keys(tmp_path: Path) -> None:
    out = tmp_path / "dir" / "commands.jsonl"  # its own folder is made (not a deeper tree)
    driver = RecordDriver(RecordConfig(out=str(out)))
    before = time.time_ns()
    await driver.connect()
    await driver.send({"jaw": 1500.0, "brow": 1234.56789}, CommandInfo(7, 1111, True))
    await driver.neutral({"jaw": 1500.0, "brow": 1200.0})
    after = time.time_ns()
    await driver.close()
    marker, *lines = [json.loads(line) for line in out.read_text().splitlines()]
    assert set(marker) == {"session"} and set(marker["session"]) == SESSION_KEYS
    assert before <= marker["session"]["started_ns"] <= after
    assert len(lines) == 2
    assert all(set(line) == KEYS for line in lines)
    first, second = lines
    assert first["seq"] == 0 and second["seq"] == 1
    assert (first["frame"], first["t_capture_ns"], first["face"]) == (7, 1111, True)
    assert first["servos"] == {"jaw": 1500.0, "brow": 1234.568}  # rounded to 0.001 µs
    assert (second["frame"], second["t_capture_ns"], second["face"]) == (None, None, False)
    assert second["servos"] == {"jaw": 1500.0, "brow": 1200.0}
    assert before <= first["t_sent_ns"] <= second["t_sent_ns"] <= after
    assert driver.count == 2


async def test_every_line_is_flushed_while_open(tmp_path: Path) -> None:
    out = tmp_path / "commands.jsonl"
    driver = RecordDriver(RecordConfig(out=str(out)))
    await driver.connect()
    try:
        for i in range(3):
            await driver.send({"jaw": 1500.0 + i}, CommandInfo(i, i + 1, True))
            # Another process reading the file now sees every line so far, complete.
            on_disk = out.read_bytes()
            assert on_disk.endswith(b"\n")
            assert [line.servos["jaw"] for line in read_record(out)] == [
                1500.0 + k for k in range(i + 1)
            ]
    finally:
        await driver.close()


async def _session(out: Path, *jaws: float) -> None:
    driver = RecordDriver(RecordConfig(out=str(out)), load_profile("paper16"))
    async with driver:
        for i, jaw in enumerate(jaws):
            await driver.send({"jaw": jaw}, CommandInfo(i, 1, True))


async def test_a_restart_on_the_same_file_appends_a_session_and_keeps_the_earlier_ones(
    tmp_path: Path,
) -> None:
    out = tmp_path / "commands.jsonl"
    await _session(out, 1600.0, 1610.0)
    await _session(out, 1700.0)
    sessions = read_sessions(out)
    assert [[line.servos["jaw"] for line in s.lines] for s in sessions] == [
        [1600.0, 1610.0],
        [1700.0],
    ]
    assert [line.seq for line in sessions[1].lines] == [0]  # seq counts per session
    assert all(s.info is not None and s.info.profile == "paper16" for s in sessions)
    assert sessions[0].info.started_ns < sessions[1].info.started_ns  # type: ignore[union-attr]
    assert [line.servos["jaw"] for line in read_record(out)] == [1600.0, 1610.0, 1700.0]
    assert [line.servos["jaw"] for line in read_record(out, session=-1)] == [1700.0]
    with pytest.raises(RecordError, match="has 2 sessions, not 5"):
        read_record(out, session=5)


async def test_a_line_torn_by_a_kill_is_closed_and_skipped_when_the_next_session_starts(
    tmp_path: Path,
) -> None:
    out = tmp_path / "commands.jsonl"
    await _session(out, 1600.0)
    with open(out, "ab") as handle:  # killed halfway through a line
        handle.write(b'{"seq": 1, "frame": 1, "t_capt')
    await _session(out, 1700.0)
    sessions = read_sessions(out)
    assert [s.torn for s in sessions] == [1, 0]
    assert [line.servos["jaw"] for line in read_record(out)] == [1600.0, 1700.0]


async def test_a_record_from_before_session_markers_is_kept_as_its_first_session(
    tmp_path: Path,
) -> None:
    out = tmp_path / "commands.jsonl"
    old = {"seq": 0, "frame": 0, "t_capture_ns": 1, "t_sent_ns": 2, "face": True, "servos": {}}
    out.write_text(json.dumps(old) + "\n")
    await _session(out, 1700.0)
    sessions = read_sessions(out)
    assert sessions[0].info is None and len(sessions[0].lines) == 1
    assert sessions[1].info is not None and len(sessions[1].lines) == 1


@pytest.mark.parametrize(
    "bad",
    [b"old content\n", b'{"seq": "x"}\n', b"\xff\xfe\n", b'{"session": {}}\n'],
    ids=["text", "wrong-type", "binary", "marker-without-time"],
)
def test_a_broken_line_inside_a_session_is_an_error_naming_it(tmp_path: Path, bad: bytes) -> None:
    out = tmp_path / "commands.jsonl"
    good = (
        b'{"seq": 0, "frame": 0, "t_capture_ns": 1, "t_sent_ns": 2, "face": true, "servos": {}}\n'
    )
    out.write_bytes(good + bad + good)
    with pytest.raises(RecordError, match=r"line 2 is neither a command nor a session marker"):
        read_record(out)


def test_reading_a_missing_record_is_an_error(tmp_path: Path) -> None:
    with pytest.raises(RecordError, match="cannot read record file"):
        read_record(tmp_path / "gone.jsonl")


def test_read_record_ignores_a_torn_last_line(tmp_path: Path) -> None:
    out = tmp_path / "commands.jsonl"
    good = [
        {
            "seq": i,
            "frame": i,
            "t_capture_ns": 10 + i,
            "t_sent_ns": 20 + i,
            "face": True,
            "servos": {"jaw": 1500.0 + i},
        }
        for i in range(2)
    ]
    text = "".join(json.dumps(line) + "\n" for line in good)
    out.write_text(text + '{"seq": 2, "frame": 2, "t_capt')
    lines = read_record(out)
    assert lines == [RecordLine(**line) for line in good]  # type: ignore[arg-type]
    out.write_text(text + json.dumps(good[0]))  # complete JSON but no newline: still torn
    assert len(read_record(out)) == 2


async def test_send_before_connect(tmp_path: Path) -> None:
    driver = RecordDriver(RecordConfig(out=str(tmp_path / "x.jsonl")))
    with pytest.raises(DriverError, match="record driver is not connected"):
        await driver.send({"jaw": 1500.0}, CommandInfo(0, 0, True))


async def test_send_after_close(tmp_path: Path) -> None:
    driver = RecordDriver(RecordConfig(out=str(tmp_path / "x.jsonl")))
    await driver.connect()
    await driver.close()
    await driver.close()  # closing twice is harmless
    with pytest.raises(DriverError, match="not connected"):
        await driver.send({"jaw": 1500.0}, CommandInfo(0, 0, True))


async def test_an_unwritable_record_path_is_refused_before_anything_connects(
    tmp_path: Path,
) -> None:
    folder = tmp_path / "a-folder"
    folder.mkdir()
    with pytest.raises(DriverConfigError, match=f"record file {re.escape(str(folder))} is a dir"):
        RecordDriver(RecordConfig(out=str(folder)))
    blocker = tmp_path / "file"
    blocker.write_text("")
    with pytest.raises(DriverConfigError, match="file is not a directory"):
        RecordDriver(RecordConfig(out=str(blocker / "sub" / "x.jsonl")))
    with pytest.raises(DriverConfigError, match="/proc is not writable"):
        RecordDriver(RecordConfig(out="/proc/facesynth/x.jsonl"))


async def test_a_path_that_breaks_after_the_check_fails_at_connect(tmp_path: Path) -> None:
    out = tmp_path / "later"
    driver = RecordDriver(RecordConfig(out=str(out)))
    out.mkdir()  # someone made it a folder meanwhile
    with pytest.raises(DriverError, match=f"cannot open record file {re.escape(str(out))}"):
        await driver.connect()


# --- configuration ----------------------------------------------------------------------------


def test_parse_record_config() -> None:
    config = DRIVERS.parse({"driver": "record", "out": "c.jsonl"})
    assert config == RecordConfig(out="c.jsonl")
    driver = DRIVERS.build(config, None)
    assert isinstance(driver, RecordDriver)
    assert driver.path == Path("c.jsonl")


@pytest.mark.parametrize(
    ("data", "detail"),
    [
        ({"driver": "serial", "out": "x"}, "unknown driver 'serial' (known: "),
        ({"driver": 3, "out": "x"}, "a driver needs driver = NAME (known: "),
        ({"driver": "record"}, "Object missing required field `out`"),
        ({"driver": "record", "out": 5}, "Expected `str`, got `int` - at `$.out`"),
        ({"driver": "record", "out": "x", "baud": 9600}, "Object contains unknown field `baud`"),
    ],
    ids=[
        "unknown-driver",
        "driver-not-a-string",
        "missing-out",
        "out-not-a-string",
        "unknown-field",
    ],
)
def test_bad_driver_configs(data: dict[str, object], detail: str) -> None:
    with pytest.raises(PluginError) as info:
        DRIVERS.parse(data, "rig.toml")
    message = str(info.value)
    assert message.startswith("rig.toml: ")
    assert detail in message


@pytest.mark.parametrize(
    ("name", "text"),
    [
        ("driver.toml", 'driver = "record"\nout = "rec.jsonl"\n'),
        ("driver.json", '{"driver": "record", "out": "rec.jsonl"}'),
        ("driver.cfg", 'driver = "record"\nout = "rec.jsonl"\n'),
    ],
    ids=["toml", "json", "other-suffix-is-toml"],
)
def test_load_driver_config(tmp_path: Path, name: str, text: str) -> None:
    path = tmp_path / name
    path.write_text(text)
    assert DRIVERS.load(path) == RecordConfig(out="rec.jsonl")


@pytest.mark.parametrize(
    ("name", "content", "detail"),
    [
        ("bad.toml", b'driver = "record\n', "not valid TOML"),
        ("bad.json", b'{"driver": "record",', "not valid JSON"),
        ("bad.json", b'["record"]', "expected a table of settings"),
        ("bad.json", b'"record"', "expected a table of settings"),
        ("bad.toml", b'driver = "nope"\nout = "x"\n', "unknown driver 'nope'"),
        ("bad.toml", b'driver = "record"\nout = "caf\xe9"\n', "cannot read driver config"),
        ("noext", b"driver = \n", "not valid TOML"),
    ],
    ids=[
        "bad-toml",
        "bad-json",
        "json-array",
        "json-string",
        "unknown-driver",
        "not-utf8",
        "no-suffix",
    ],
)
def test_bad_driver_config_files(tmp_path: Path, name: str, content: bytes, detail: str) -> None:
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(PluginError) as info:
        DRIVERS.load(path)
    message = str(info.value)
    assert str(path) in message
    assert detail in message


def test_missing_driver_config(tmp_path: Path) -> None:
    path = tmp_path / "gone.toml"
    where = re.escape(str(path))
    with pytest.raises(PluginError, match=f"cannot read driver config {where}"):
        DRIVERS.load(path)


async def test_a_driver_is_an_async_context_manager_that_connects_and_closes(
    tmp_path: Path,
) -> None:
    out = tmp_path / "commands.jsonl"
    driver = RecordDriver(RecordConfig(out=str(out)))
    with pytest.raises(KeyError, match="boom"):
        async with driver as entered:
            assert entered is driver and out.exists()
            await driver.send({"jaw": 1600.0}, CommandInfo(0, 1, True))
            raise KeyError("boom")
    with pytest.raises(DriverError, match="not connected"):  # closed on the way out
        await driver.send({"jaw": 1500.0}, CommandInfo(1, 1, True))
    # Leaving does not move the face: only what was sent is on file.
    assert [line.servos for line in read_record(out)] == [{"jaw": 1600.0}]


async def test_each_session_says_whether_it_created_or_appended_to_its_file(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """`make demo` appended to facesynth-commands.jsonl without a word (issue 29)."""
    caplog.set_level(logging.INFO, "facesynth.control")
    out = tmp_path / "commands.jsonl"
    for jaw in (1600.0, 1700.0, 1800.0):
        await _session(out, jaw)
    said = [r.getMessage() for r in caplog.records if r.getMessage().startswith("record file")]
    assert said == [
        f"record file {out}: created (one session)",
        f"record file {out}: appended session 2 after 1 earlier session "
        "(a record file is never truncated)",
        f"record file {out}: appended session 3 after 2 earlier sessions "
        "(a record file is never truncated)",
    ]
    assert earlier_sessions(out) == len(read_sessions(out)) == 3


def test_earlier_sessions_counts_what_a_file_holds_without_decoding_it(tmp_path: Path) -> None:
    out = tmp_path / "commands.jsonl"
    assert earlier_sessions(out) == 0  # no file yet
    out.write_bytes(b"")
    assert earlier_sessions(out) == 0  # empty: the next session is its first
    old = {"seq": 0, "frame": 0, "t_capture_ns": 1, "t_sent_ns": 2, "face": True, "servos": {}}
    out.write_text(json.dumps(old) + "\n")  # commands from before session markers
    assert earlier_sessions(out) == 1
    marker = json.dumps({"session": {"started_ns": 1}})
    out.write_text(json.dumps(old) + "\n" + marker + "\n" + json.dumps(old) + "\n" + marker)
    assert earlier_sessions(out) == 3  # the last marker torn of its newline still counts
    assert record_summary(out, 0) == {"out": str(out), "file": "created", "sessions": 1}
    assert record_summary(out, 3) == {"out": str(out), "file": "appended", "sessions": 4}
