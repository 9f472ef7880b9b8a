"""`record`, `replay`, `inspect`, `convert`: help, and one clear error (exit 2) for bad input."""

from __future__ import annotations

import importlib
from pathlib import Path

import pytest
from mcap.writer import Writer

from facesynth.app.cli import main
from facesynth.app.recording.convert import landmarks_to_mcap

OPENFACE = Path(__file__).parents[3] / "facesynth" / "app" / "data" / "OpenFace_Test.csv"


@pytest.mark.parametrize("command", ["record", "replay", "inspect", "convert"])
def test_help(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main([command, "--help"])
    assert exit_info.value.code == 0
    assert "usage: facesynth " + command in capsys.readouterr().out


def _files(tmp: Path) -> dict[str, Path]:
    files = {
        "text.mcap": tmp / "text.mcap",
        "foreign.mcap": tmp / "foreign.mcap",
        "points.mcap": tmp / "points.mcap",
        "torn.mcap": tmp / "torn.mcap",
        "existing.mcap": tmp / "existing.mcap",
        "garbage.csv": tmp / "garbage.csv",
        "notes.txt": tmp / "notes.txt",
        "new.mcap": tmp / "new.mcap",
    }
    files["text.mcap"].write_text("hello\n")
    files["existing.mcap"].write_bytes(b"keep me")
    files["garbage.csv"].write_text("a, b\n1, 2\n")
    files["notes.txt"].write_text("notes\n")
    with open(files["foreign.mcap"], "wb") as handle:
        writer = Writer(handle)
        writer.start(profile="ros2", library="rosbag2")
        writer.finish()
    landmarks_to_mcap(OPENFACE, files["points.mcap"])
    data = files["points.mcap"].read_bytes()
    files["torn.mcap"].write_bytes(data[: len(data) // 2])
    return files


CASES = [
    ("record without out", ["record"], "give --out"),
    (
        "record unknown key",
        ["record", "--out", "{new.mcap}", "--keys", "ears"],
        "unknown key 'ears'",
    ),
    ("record existing file", ["record", "--out", "{existing.mcap}"], "exists (give --overwrite"),
    (
        "record bad chunk time",
        ["record", "--out", "{new.mcap}", "--chunk-seconds", "0"],
        "chunk time",
    ),
    (
        "record bad frame-every",
        ["record", "--out", "{new.mcap}", "--frame-every", "-1"],
        "--frame-every",
    ),
    ("check not MCAP", ["record", "--check", "{text.mcap}"], "is not an MCAP file"),
    ("check missing", ["record", "--check", "/nonexistent/s.mcap"], "cannot read"),
    (
        "check foreign",
        ["record", "--check", "{foreign.mcap}"],
        "not a facesynth recording (profile 'ros2'",
    ),
    ("replay not MCAP", ["replay", "{text.mcap}"], "is not an MCAP file"),
    ("replay foreign", ["replay", "{foreign.mcap}"], "not a facesynth recording"),
    ("replay torn", ["replay", "{torn.mcap}"], "is torn"),
    (
        "replay absent stage",
        ["replay", "{points.mcap}", "--from", "input"],
        "holds no input messages",
    ),
    ("replay bad speed", ["replay", "{points.mcap}", "--speed", "0"], "--speed"),
    ("replay bad window", ["replay", "{points.mcap}", "--fast", "--window", "0"], "--window"),
    ("inspect bad address", ["inspect", "--foxglove", "nowhere:port"], "bad Foxglove address"),
    ("convert unknown kind", ["convert", "{notes.txt}", "{new.mcap}"], "reads OpenFace .csv"),
    ("convert bad OpenFace", ["convert", "{garbage.csv}", "{new.mcap}"], "missing columns"),
    ("convert to a video", ["convert", "{points.mcap}", "out.mp4"], "converts to .jsonl or .csv"),
    (
        "convert bad size",
        ["convert", str(OPENFACE), "{new.mcap}", "--size", "big"],
        "bad image size",
    ),
    ("convert no commands", ["convert", "{points.mcap}", "out.jsonl"], "holds no servo commands"),
    ("convert onto a file", ["convert", str(OPENFACE), "{existing.mcap}"], "exists"),
    ("convert torn", ["convert", "{torn.mcap}", "out.csv"], "is torn"),
]


@pytest.mark.parametrize(("argv", "expected"), [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_input_gives_one_clear_error(
    argv: list[str], expected: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    files = _files(tmp_path)
    argv = [str(files[a[1:-1]]) if a.startswith("{") else a for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    last = err.strip().splitlines()[-1]
    assert last.startswith(f"facesynth {argv[0]}: error: ")
    assert expected in last
    assert "Traceback" not in err
    assert files["existing.mcap"].read_bytes() == b"keep me"


def test_a_missing_extra_is_named(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    real = importlib.import_module

    def without_foxglove(name: str, *args: object) -> object:
        if name == "foxglove":
            raise ImportError("No module named 'foxglove'")
        return real(name, *args)  # type: ignore[arg-type]

    monkeypatch.setattr(importlib, "import_module", without_foxglove)
    assert main(["inspect"]) == 2
    assert "pip install 'facesynth[record]'" in capsys.readouterr().err


def test_an_unknown_key_is_named_on_one_line() -> None:
    """A newline typed into --keys stayed in the message (found by tests/fuzz)."""
    from facesynth.app.recording.recorder import RecordOptionError, parse_keys

    with pytest.raises(RecordOptionError) as info:
        parse_keys("input,ea\nrs")
    assert "'ea\\nrs'" in str(info.value) and "\n" not in str(info.value)
