"""The written profiles' likeness cannot silently go backwards (issue 27): ``bench robot``'s
figures of paper16, head16 and head16_bs on simhead16, kept in
``facesynth/app/bench/robot_kept.json``, are measured again and compared
(facesynth.app.bench.robot_kept). Measuring takes about 15 s of CPU (120 frames of the bundled
video, her laugh, three profiles)."""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import pytest

from facesynth.app.bench.robot import DEFAULT_PROFILES
from facesynth.app.bench.robot_kept import (
    FIGURES,
    HEAD,
    KEPT_FILE,
    SEGMENT_FRAMES,
    SEGMENT_START,
    TOLERANCE,
    load_kept,
    measure_kept,
    went_backwards,
)

KEPT: dict[str, Any] = {
    "heads": {
        "h": {
            "p": {"mean_rho": 0.40, "mean_rho_all_moved": 0.35, "in_band": 0.2, "median_ratio": 0.9}
        }
    }
}


def _with(figure: str, value: float | None) -> dict[str, Any]:
    measured = copy.deepcopy(KEPT)
    measured["heads"]["h"]["p"][figure] = value
    return measured


def test_the_table_keeps_every_written_profile() -> None:
    kept = load_kept()
    assert kept["start"] == SEGMENT_START and kept["frames"] == SEGMENT_FRAMES
    assert kept["tolerance"] == TOLERANCE
    assert set(kept["heads"]) == {HEAD}
    assert list(kept["heads"][HEAD]) == list(DEFAULT_PROFILES)
    for figures in kept["heads"][HEAD].values():
        assert set(figures) == set(FIGURES)
    assert kept["command"] == "python -m facesynth.app.bench.robot_kept --write"


def test_the_written_profiles_did_not_go_backwards() -> None:
    """Measured again now: no kept figure lost more than the tolerance."""
    measured = measure_kept()
    assert went_backwards(load_kept(), measured) == []


@pytest.mark.parametrize(
    ("figure", "value", "backwards"),
    [
        ("mean_rho", 0.36, False),  # within the tolerance
        ("mean_rho", 0.34, True),
        ("mean_rho", 0.90, False),  # better
        ("mean_rho_all_moved", 0.29, True),
        ("in_band", 0.14, True),
        ("median_ratio", 0.84, True),  # further from 1
        ("median_ratio", 1.16, True),
        ("median_ratio", 0.95, False),  # closer to 1
        ("mean_rho", None, True),  # no longer measured
    ],
)
def test_a_figure_that_drops_beyond_the_tolerance_is_reported(
    figure: str, value: float | None, backwards: bool
) -> None:
    lines = went_backwards(KEPT, _with(figure, value), tolerance=0.05)
    assert bool(lines) == backwards, lines
    if backwards:
        assert lines[0].startswith(f"h / p: {figure} ")


def test_a_profile_no_longer_measured_is_reported() -> None:
    assert went_backwards(KEPT, {"heads": {}}) == ["h / p: not measured"]


def test_a_file_that_is_not_a_table_is_a_clear_error(tmp_path: Path) -> None:
    bad = tmp_path / "kept.json"
    bad.write_text("{not json", encoding="utf-8")
    with pytest.raises(ValueError, match="not a kept bench robot table"):
        load_kept(bad)
    bad.write_text(json.dumps({"frames": 1}), encoding="utf-8")
    with pytest.raises(ValueError, match="no heads"):
        load_kept(bad)
    assert KEPT_FILE.name == "robot_kept.json"
