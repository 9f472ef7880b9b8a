"""Read OpenFace 2 ``FeatureExtraction`` CSV output (68 landmarks per frame).

Both header styles are accepted (with or without a space after each comma). Rows where OpenFace
reports ``success`` 0 become "no face" frames. Malformed files raise :class:`OpenFaceError` naming
the line and the column.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from facesynth.runtime.landmarks import N_IBUG

REQUIRED = ("frame", "success", "confidence")


class OpenFaceError(ValueError):
    """An OpenFace CSV that cannot be replayed."""


@dataclass(frozen=True)
class OpenFaceRow:
    """One frame of OpenFace output."""

    frame: int
    confidence: float
    success: bool
    points: np.ndarray  # (68, 2) pixels


def parse_openface_csv(text: str, source: str = "<csv>") -> list[OpenFaceRow]:
    """Parse OpenFace CSV text into rows ordered by frame number."""
    reader = csv.reader(io.StringIO(text))
    try:
        header = [name.strip() for name in next(reader)]
    except StopIteration:
        raise OpenFaceError(f"{source}: the file is empty") from None
    except csv.Error as exc:
        raise OpenFaceError(f"{source}: not CSV: {exc}") from None
    columns = {name: i for i, name in enumerate(header)}
    needed = [*REQUIRED, *(f"x_{i}" for i in range(N_IBUG)), *(f"y_{i}" for i in range(N_IBUG))]
    missing = [name for name in needed if name not in columns]
    if missing:
        shown = ", ".join(missing[:6]) + (" …" if len(missing) > 6 else "")
        raise OpenFaceError(f"{source}: not OpenFace landmark output (missing columns: {shown})")
    xs = [columns[f"x_{i}"] for i in range(N_IBUG)]
    ys = [columns[f"y_{i}"] for i in range(N_IBUG)]
    rows: list[OpenFaceRow] = []
    try:
        for line_no, fields in enumerate(reader, start=2):
            if not fields or all(not f.strip() for f in fields):
                continue
            if len(fields) < len(header):
                raise OpenFaceError(
                    f"{source}:{line_no}: {len(fields)} fields, the header has {len(header)}"
                )
            rows.append(_row(fields, columns, xs, ys, f"{source}:{line_no}"))
    except csv.Error as exc:
        raise OpenFaceError(f"{source}: not CSV: {exc}") from None
    if not rows:
        raise OpenFaceError(f"{source}: no data rows")
    rows.sort(key=lambda row: row.frame)
    return rows


def _number(fields: list[str], index: int, name: str, where: str) -> float:
    try:
        value = float(fields[index])
    except ValueError:
        raise OpenFaceError(
            f"{where}: column {name} is {fields[index].strip()!r}, not a number"
        ) from None
    if not math.isfinite(value):
        raise OpenFaceError(f"{where}: column {name} is {value}")
    return value


def _row(
    fields: list[str], columns: dict[str, int], xs: list[int], ys: list[int], where: str
) -> OpenFaceRow:
    frame = _number(fields, columns["frame"], "frame", where)
    if frame != int(frame) or frame < 0:
        raise OpenFaceError(f"{where}: frame number {frame} is not a whole number >= 0")
    success = _number(fields, columns["success"], "success", where) >= 0.5
    confidence = _number(fields, columns["confidence"], "confidence", where)
    points = np.array(
        [
            [_number(fields, x, f"x_{i}", where), _number(fields, y, f"y_{i}", where)]
            for i, (x, y) in enumerate(zip(xs, ys, strict=True))
        ]
    )
    return OpenFaceRow(int(frame), confidence, success, points)


def load_openface_csv(path: str | Path) -> list[OpenFaceRow]:
    """Read and parse an OpenFace CSV file."""
    file = Path(path)
    try:
        text = file.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise OpenFaceError(f"cannot read {file}: {exc}") from None
    return parse_openface_csv(text, str(file))
