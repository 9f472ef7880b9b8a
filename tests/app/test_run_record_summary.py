"""``facesynth run`` (and ``make demo``) says in its summary whether it created its record file
or appended a session to it (issue 29: it appended to facesynth-commands.jsonl without a word)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from facesynth.app.cli import main
from facesynth.services.control.drivers.record import read_sessions


def _run(out: Path, capsys: pytest.CaptureFixture[str]) -> dict[str, object]:
    argv = ["run", "--max-frames", "3", "--fast", "--out", str(out)]
    assert main([*argv, "--listen", "tcp/127.0.0.1:0"]) == 0
    summary: dict[str, object] = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    return summary


def test_the_summary_says_created_then_appended(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "facesynth-commands.jsonl"
    first = _run(out, capsys)
    assert first["record"] == {"out": str(out), "file": "created", "sessions": 1}
    second = _run(out, capsys)
    assert second["record"] == {"out": str(out), "file": "appended", "sessions": 2}
    assert len(read_sessions(out)) == 2
    assert second["out"] == str(out)  # the key scripts read is kept
