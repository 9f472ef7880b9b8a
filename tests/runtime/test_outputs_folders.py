"""Output paths into missing folders (issue 20): the file's own folder is made, and said; a
deeper missing tree is refused (a typo would otherwise grow a new tree)."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest

from facesynth.runtime.outputs import OutputError, check_output


def test_the_files_own_missing_folder_is_fine_and_logged(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    target = tmp_path / "takes" / "c.jsonl"
    with caplog.at_level(logging.INFO, logger="facesynth.outputs"):
        assert check_output(target, "record file") == target
    assert [r.getMessage() for r in caplog.records] == [
        f"record file {target}: making its folder {tmp_path / 'takes'}"
    ]
    assert not (tmp_path / "takes").exists()  # the writer makes it, not the check


def test_a_deeper_missing_tree_is_refused(tmp_path: Path) -> None:
    target = tmp_path / "tkaes" / "monday" / "c.jsonl"
    with pytest.raises(OutputError, match=f"folder {tmp_path / 'tkaes'} does not exist"):
        check_output(target, "record file")
    assert not (tmp_path / "tkaes").exists()


def test_facesynths_own_default_places_are_made_whole(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    target = tmp_path / ".config" / "facesynth" / "calibrations" / "alice.json"
    with caplog.at_level(logging.INFO, logger="facesynth.outputs"):
        assert check_output(target, "calibration", make_parents=True) == target
    assert not caplog.records
