"""facesynth.services.points.openface_csv: the real OpenFace 2 CSV, and malformed variants of it."""

from __future__ import annotations

import csv
import re
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from facesynth.services.points.openface_csv import (
    OpenFaceError,
    load_openface_csv,
    parse_openface_csv,
)


def _real_text() -> str:
    path = resources.files("facesynth.app.data") / "OpenFace_Test.csv"
    return path.read_text(encoding="utf-8")


REAL = _real_text()
HEADER, *DATA = REAL.splitlines()
NAMES = [name.strip() for name in HEADER.split(",")]


def _col(name: str) -> int:
    return NAMES.index(name)


def _csv(header: list[str], rows: list[list[str]]) -> str:
    return "\n".join(", ".join(fields) for fields in [header, *rows]) + "\n"


def _rows(count: int = 3) -> list[list[str]]:
    return [[f.strip() for f in line.split(",")] for line in DATA[:count]]


# --- the real file ----------------------------------------------------------------------------


def test_real_csv() -> None:
    rows = parse_openface_csv(REAL)
    assert len(rows) == 100
    assert [row.frame for row in rows] == list(range(1, 101))
    assert all(row.success for row in rows)
    first = next(csv.reader([DATA[0]], skipinitialspace=True))
    assert rows[0].confidence == float(first[_col("confidence")])
    assert rows[0].points.shape == (68, 2)
    for i in (0, 30, 36, 45, 67):
        assert rows[0].points[i, 0] == float(first[_col(f"x_{i}")])
        assert rows[0].points[i, 1] == float(first[_col(f"y_{i}")])
    # A plausible face in a 640x360 video: eyes above the nose, the right eye on the image left.
    points = rows[0].points
    assert points[36, 0] < points[30, 0] < points[45, 0]
    assert points[36, 1] < points[30, 1] < points[8, 1]


def test_load_from_file(tmp_path: Path) -> None:
    path = tmp_path / "of.csv"
    path.write_text(REAL)
    rows = load_openface_csv(path)
    assert len(rows) == 100
    np.testing.assert_array_equal(rows[5].points, parse_openface_csv(REAL)[5].points)


def test_header_without_spaces_gives_the_same_rows() -> None:
    compact = REAL.replace(", ", ",")
    assert compact != REAL
    for a, b in zip(parse_openface_csv(compact), parse_openface_csv(REAL), strict=True):
        assert (a.frame, a.confidence, a.success) == (b.frame, b.confidence, b.success)
        np.testing.assert_array_equal(a.points, b.points)


def test_rows_are_ordered_by_frame_and_blank_lines_skipped() -> None:
    text = "\n".join([HEADER, DATA[2], "", DATA[0], " , ", DATA[1]]) + "\n"
    assert [row.frame for row in parse_openface_csv(text)] == [1, 2, 3]


@pytest.mark.parametrize(
    ("value", "success"),
    [("0", False), ("1", True), ("0.0", False), ("1.0", True)],
    ids=["0", "1", "0.0", "1.0"],
)
def test_success_flag(value: str, success: bool) -> None:
    rows = _rows(2)
    rows[1][_col("success")] = value
    parsed = parse_openface_csv(_csv(NAMES, rows))
    assert parsed[0].success is True
    assert parsed[1].success is success


# --- malformed files --------------------------------------------------------------------------


def _with(row: int, column: str, value: str) -> str:
    rows = _rows(3)
    rows[row][_col(column)] = value
    return _csv(NAMES, rows)


def _without(*columns: str) -> str:
    keep = [i for i, name in enumerate(NAMES) if name not in columns]
    rows = [[row[i] for i in keep] for row in _rows(2)]
    return _csv([NAMES[i] for i in keep], rows)


@pytest.mark.parametrize(
    ("text", "detail"),
    [
        ("", "of.csv: the file is empty"),
        (HEADER + "\n", "of.csv: no data rows"),
        (HEADER + "\n\n  \n", "of.csv: no data rows"),
        (_without("x_5"), "of.csv: not OpenFace landmark output (missing columns: x_5)"),
        (_without("success"), "missing columns: success"),
        (
            _without(*[f"y_{i}" for i in range(10)]),
            "missing columns: y_0, y_1, y_2, y_3, y_4, y_5 …",
        ),
        ("a,b,c\n1,2,3\n", "missing columns: frame, success, confidence, x_0, x_1, x_2 …"),
        (_with(1, "y_7", "abc"), "of.csv:3: column y_7 is 'abc', not a number"),
        (_with(0, "x_0", ""), "of.csv:2: column x_0 is '', not a number"),
        (_with(2, "confidence", "high"), "of.csv:4: column confidence is 'high', not a number"),
        (_with(0, "x_12", "nan"), "of.csv:2: column x_12 is nan"),
        (_with(1, "y_67", "-inf"), "of.csv:3: column y_67 is -inf"),
        (_with(0, "confidence", "NaN"), "of.csv:2: column confidence is nan"),
        (_with(0, "frame", "1.5"), "of.csv:2: frame number 1.5 is not a whole number >= 0"),
        (_with(0, "frame", "-1"), "of.csv:2: frame number -1.0 is not a whole number >= 0"),
        (
            HEADER + "\n" + DATA[0] + "\n" + ", ".join(_rows(2)[1][:10]) + "\n",
            f"of.csv:3: 10 fields, the header has {len(NAMES)}",
        ),
    ],
    ids=[
        "empty",
        "header-only",
        "header-and-blanks",
        "missing-x5",
        "missing-success",
        "many-missing-truncated",
        "not-openface",
        "non-numeric",
        "empty-value",
        "non-numeric-confidence",
        "nan",
        "minus-inf",
        "nan-confidence",
        "fractional-frame",
        "negative-frame",
        "short-row",
    ],
)
def test_malformed_csv(text: str, detail: str) -> None:
    with pytest.raises(OpenFaceError) as info:
        parse_openface_csv(text, "of.csv")
    assert detail in str(info.value)
    assert str(info.value).startswith("of.csv")


def test_missing_file(tmp_path: Path) -> None:
    path = tmp_path / "gone.csv"
    with pytest.raises(OpenFaceError, match=f"cannot read {re.escape(str(path))}"):
        load_openface_csv(path)


def test_non_utf8_file(tmp_path: Path) -> None:
    path = tmp_path / "latin1.csv"
    path.write_bytes(HEADER.encode() + b"\n\xe9\xff\n")
    with pytest.raises(OpenFaceError, match=f"cannot read {re.escape(str(path))}: .*utf-8"):
        load_openface_csv(path)


def test_errors_name_the_file(tmp_path: Path) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(_with(1, "x_3", "?"))
    where = re.escape(str(path))
    with pytest.raises(OpenFaceError, match=f"^{where}:3: column x_3 is '\\?', not a number$"):
        load_openface_csv(path)
