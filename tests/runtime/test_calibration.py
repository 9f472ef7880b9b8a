"""runtime.calibration: load, validate and atomically save calibrations."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

import msgspec
import pytest

from facesynth.runtime import calibration
from facesynth.runtime.calibration import (
    Calibration,
    CalibrationError,
    load_calibration,
    parse_calibration,
    save_calibration,
)

pytestmark = pytest.mark.usefixtures("isolated_home")  # no user calibrations


def _calibration(**kw: Any) -> Calibration:
    fields: dict[str, Any] = dict(
        name="ann",
        neutral=[0.5 + i / 100 for i in range(68)],
        delta_min=[-0.01 * (i % 5) for i in range(68)],
        delta_max=[0.02 * (i % 7) for i in range(68)],
        created="2026-01-01T00:00:00Z",
    )
    fields.update(kw)
    return Calibration(**fields)


def _json(**kw: Any) -> str:
    data = msgspec.to_builtins(_calibration())
    data.update(kw)
    return json.dumps(data)


def test_round_trip(tmp_path: Path) -> None:
    original = _calibration()
    path = save_calibration(original, tmp_path / "sub" / "ann.json")
    assert path == tmp_path / "sub" / "ann.json"
    assert load_calibration(str(path)) == original
    on_disk = json.loads(path.read_text())
    assert on_disk["format"] == "facesynth.runtime.calibration"
    assert on_disk["version"] == 1
    assert on_disk["feature"] == "nose_distance"


def test_lookup_by_name(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    home_dir = tmp_path / "home" / ".config" / "facesynth" / "calibrations"
    save_calibration(_calibration(name="home"), home_dir / "ann.json")
    assert load_calibration("ann").name == "home"
    env_dir = tmp_path / "env"
    save_calibration(_calibration(name="env"), env_dir / "ann.json")
    monkeypatch.setenv("FACESYNTH_CALIBRATIONS", str(env_dir))
    assert load_calibration("ann").name == "env"  # $FACESYNTH_CALIBRATIONS comes first


def test_unknown_name_says_where_it_looked(tmp_path: Path) -> None:
    with pytest.raises(CalibrationError) as info:
        load_calibration("bob")
    text = str(info.value)
    assert "no calibration named 'bob'" in text
    assert str(tmp_path / "home" / ".config" / "facesynth" / "calibrations") in text


@pytest.mark.parametrize("name", ["gone.json", "dir/gone"], ids=["suffix", "separator"])
def test_missing_file(tmp_path: Path, name: str) -> None:
    path = tmp_path / name
    where = re.escape(str(path))
    with pytest.raises(CalibrationError, match=f"calibration file {where} does not exist"):
        load_calibration(str(path))


@pytest.mark.parametrize(
    ("text", "detail"),
    [
        ("", "Input data was truncated"),
        ("{not json", "malformed"),
        ("[1, 2]", "Expected `object`, got `array`"),
        (_json()[:-5], "truncated"),
        (_json(neutral=[0.5] * 67), "neutral has 67 values, needs 68"),
        (_json(delta_min=[0.0] * 69), "delta_min has 69 values, needs 68"),
        (_json(delta_max=[]), "delta_max has 0 values, needs 68"),
        (
            _json(neutral=[123.25] + [0.5] * 67).replace("123.25", "1e999"),
            "Number out of range - at `$.neutral[0]`",
        ),
        (_json(neutral=[1e999] + [0.5] * 67), "JSON is malformed"),
        (_json(neutral=[0.5] * 67 + ["NaN"]), "Expected `float`, got `str` - at `$.neutral[67]`"),
        (_json(neutral=[-0.1] + [0.5] * 67), "neutral distances cannot be negative"),
        (
            _json(delta_min=[0.0] * 10 + [0.01] + [0.0] * 57),
            "points [10] need delta_min <= 0 <= delta_max",
        ),
        (
            _json(delta_max=[0.0] * 66 + [-0.01, -0.2]),
            "points [66, 67] need delta_min <= 0 <= delta_max",
        ),
        (_json(version=2), "version 2 is not supported (this facesynth reads 1)"),
        (_json(format="other"), "Invalid enum value 'other' - at `$.format`"),
        (_json(feature="area"), "Invalid enum value 'area' - at `$.feature`"),
        (_json(scheme="mesh468"), "scheme 'mesh468' is not supported"),
        (_json(extra=1), "Object contains unknown field `extra`"),
        (
            json.dumps({"name": "x", "neutral": [], "delta_min": []}),
            "Object missing required field `delta_max`",
        ),
    ],
    ids=[
        "empty",
        "not-json",
        "array",
        "truncated",
        "short-neutral",
        "long-delta-min",
        "empty-delta-max",
        "overflow",
        "infinity-literal",
        "nan-string",
        "negative-neutral",
        "delta-min-positive",
        "delta-max-negative",
        "version-2",
        "wrong-format",
        "wrong-feature",
        "wrong-scheme",
        "unknown-field",
        "missing-field",
    ],
)
def test_invalid_calibrations(text: str, detail: str) -> None:
    with pytest.raises(CalibrationError) as info:
        parse_calibration(text, "ann.json")
    message = str(info.value)
    assert message.startswith("ann.json: ")
    assert detail in message


@pytest.mark.parametrize(
    ("field", "index", "value"),
    [
        ("neutral", 3, math.nan),
        ("delta_min", 0, -math.inf),
        ("delta_max", 67, math.inf),
        ("neutral", 5, 1e300),  # F's deltas would be refused by every receiver (tests/fuzz)
    ],
    ids=["neutral-nan", "delta-min-inf", "delta-max-inf", "neutral-huge"],
)
def test_non_finite_or_huge_values_are_refused(field: str, index: int, value: float) -> None:
    values = list(getattr(_calibration(), field))
    values[index] = value
    bad = _calibration(**{field: values})
    assert calibration.validate_calibration(bad) == [
        f"{field} has a value that is not a finite number within ±1000"
    ]


def test_load_from_file_names_the_file(tmp_path: Path) -> None:
    path = tmp_path / "ann.json"
    path.write_text(_json(version=3))
    where = re.escape(str(path))
    with pytest.raises(CalibrationError, match=f"^{where}: version 3 is not supported"):
        load_calibration(str(path))


def test_unreadable_path_is_a_calibration_error(tmp_path: Path) -> None:
    folder = tmp_path / "folder.json"
    folder.mkdir()
    with pytest.raises(CalibrationError, match="does not exist"):
        load_calibration(str(folder))


# --- atomic saving ----------------------------------------------------------------------------


def _leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".tmp"))


def test_save_leaves_no_temporary_files(tmp_path: Path) -> None:
    target = tmp_path / "ann.json"
    save_calibration(_calibration(), target)
    save_calibration(_calibration(name="again"), target)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ann.json", "home"]
    assert load_calibration(str(target)).name == "again"


def test_invalid_calibration_is_not_written(tmp_path: Path) -> None:
    target = tmp_path / "ann.json"
    save_calibration(_calibration(), target)
    before = target.read_bytes()
    bad = _calibration(delta_min=[0.5] * 68)
    with pytest.raises(CalibrationError, match=r"points \[0, 1, .*\] need delta_min <= 0"):
        save_calibration(bad, target)
    assert target.read_bytes() == before
    assert _leftovers(tmp_path) == []
