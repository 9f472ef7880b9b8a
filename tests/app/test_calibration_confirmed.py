"""`--calibration NAME` is confirmed in one log line: file, performer, when made (issue 20)."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest

from facesynth.app.wiring import build_calibration
from facesynth.runtime.calibration import Calibration, save_calibration


def test_a_calibration_is_confirmed_once_with_its_file_performer_and_date(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    monkeypatch.setenv("FACESYNTH_CALIBRATIONS", str(tmp_path))
    calibration = Calibration(
        name="alice",
        neutral=[0.5] * 68,
        delta_min=[-0.01] * 68,
        delta_max=[0.02] * 68,
        created="2026-11-20T10:00:00+00:00",
    )
    path = save_calibration(calibration, tmp_path / "alice.json")
    with caplog.at_level(logging.INFO, logger="facesynth.calibration"):
        assert build_calibration("alice") == calibration  # F's
        assert build_calibration("alice") == calibration  # and T's: one line for both
    lines = [r.getMessage() for r in caplog.records if r.name == "facesynth.calibration"]
    assert lines == [
        f"calibration alice: {path.resolve()} (performer alice, made 2026-11-20T10:00:00+00:00)"
    ]
    assert build_calibration(None) is None
