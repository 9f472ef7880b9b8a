"""``facesynth bench run``'s pure parts: the plain script's output read back, the goals'
arithmetic, the report, and the Maestro bytes the plain script writes."""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import pytest

from facesynth.app.bench.plain_mediapipe import (
    MAX_US,
    MIN_US,
    linear_map,
    maestro_bytes,
    positions_us,
)
from facesynth.app.bench.run_compare_report import (
    PlainScriptError,
    Round,
    RunFigures,
    format_run_compare,
    parse_plain,
    verdicts,
)
from facesynth.services.control.drivers.maestro import protocol


def _plain(**changes: Any) -> dict[str, Any]:
    figures = {
        "script": "plain_mediapipe",
        "mediapipe": "0.10.21",
        "frames": 300,
        "warmup": 30,
        "faces": 290,
        "cpu_ms_per_frame": 12.5,
        "model_calls_ms": 9.25,
        "wall_ms_per_frame": 13.0,
        "bytes": 35 * 300,
    }
    return {**figures, **changes}


def test_the_plain_scripts_figures_are_read_from_its_last_line() -> None:
    out = "W0000 some log line on stdout\n" + json.dumps(_plain()) + "\n\n"
    figures = parse_plain(out)
    assert figures.cpu_ms_per_frame == 12.5
    assert figures.model_calls_ms == 9.25
    assert (figures.frames, figures.faces, figures.mediapipe) == (300, 290, "0.10.21")


@pytest.mark.parametrize(
    ("stdout", "message"),
    [
        ("", "printed nothing"),
        ("\n  \n", "printed nothing"),
        ("Traceback (most recent call last):", "not its figures"),
        ('{"script": "plain_mediapipe"}', "not its figures"),
        (json.dumps({**_plain(), "extra": 1}), "not its figures"),
        (json.dumps(_plain(script="mediapipe_helper")), "not its figures"),
        (json.dumps(_plain(cpu_ms_per_frame="fast")), "not its figures"),
        (json.dumps(_plain(cpu_ms_per_frame=-1.0)), "bad times"),
        (json.dumps(_plain(model_calls_ms=float("nan"))), "not its figures"),  # NaN: not JSON
        (json.dumps(_plain(wall_ms_per_frame=-0.5)), "bad times"),
        (json.dumps(_plain(frames=0, bytes=0)), "faces in 0 frames"),
        (json.dumps(_plain(faces=301)), "301 faces in 300 frames"),
        (json.dumps(_plain(bytes=34 * 300)), "not 35 a frame"),
    ],
)
def test_malformed_plain_output_is_one_clear_error(stdout: str, message: str) -> None:
    with pytest.raises(PlainScriptError, match=message):
        parse_plain(stdout)


def test_run_cpu_is_the_long_run_less_the_short_one_per_frame() -> None:
    figures = RunFigures(
        long_cpu_s=5.0, short_cpu_s=2.0, frames=300, commands=330, model_calls_ms=8
    )
    assert figures.cpu_ms_per_frame == pytest.approx(10.0)


def test_verdicts_against_model_calls_and_the_plain_script() -> None:
    beyond, ratio = verdicts(9.0, 7.5, 12.0)
    assert (beyond.limit, beyond.met) == (9.5, True)
    assert "met by 0.50 ms" in beyond.line()
    assert ratio.limit == pytest.approx(8.4)
    assert not ratio.met
    assert "missed by 0.60 ms" in ratio.line()
    (only,) = verdicts(9.5, 7.5, None)  # without the plain script: one goal; equal is met
    assert only.met


def test_the_report_takes_medians_and_says_when_the_plain_script_did_not_run() -> None:
    def round_(cpu_s: float, plain_ms: float | None) -> Round:
        run = RunFigures(cpu_s, 0.0, 1000, 1030, 8.0, 36050)
        plain = parse_plain(json.dumps(_plain(cpu_ms_per_frame=plain_ms))) if plain_ms else None
        return Round(run, plain)

    common = {"video": "v.mp4", "frames": 1000, "warmup": 30, "driver": "maestro", "load": "x"}
    both = format_run_compare(
        [round_(10.0, 14.0), round_(12.0, 15.0), round_(30.0, 20.0)], **common
    )
    assert "run 12.00 (model calls 8.00, the rest 4.00); plain script 15.00" in both
    assert "run ≤ model calls + 2 ms: 12.00 ≤ 10.00 ms — missed by 2.00 ms" in both
    assert "run ≤ 0.7 × plain script: 12.00 ≤ 10.50 ms — missed by 1.50 ms" in both
    assert "36050 bytes to the Maestro" in both
    assert "not run" not in both
    alone = format_run_compare([round_(9.0, None)], **common)
    assert "the plain MediaPipe script was not run" in alone
    assert "0.7 × plain" not in alone
    assert "run ≤ model calls + 2 ms: 9.00 ≤ 10.00 ms — met by 1.00 ms" in alone


def test_the_plain_script_writes_the_maestros_own_set_multiple_targets() -> None:
    positions = np.array([992.0, 1500.0, 2000.0, 1234.56] * 4)
    quarters = [round(p * 4) for p in positions]
    assert maestro_bytes(positions) == protocol.set_multiple_targets(0, quarters)
    assert len(maestro_bytes(positions)) == 35


def test_the_plain_scripts_map_keeps_positions_in_range() -> None:
    weights = linear_map()
    assert weights.shape == (16, 52)
    assert np.array_equal(weights, linear_map())  # fixed: every run maps alike
    assert np.array_equal(positions_us(weights, np.zeros(52)), np.full(16, 1500.0))
    for scores in (np.ones(52), -np.ones(52) * 10, np.ones(52) * 10):
        moved = positions_us(weights, scores)
        assert moved.min() >= MIN_US and moved.max() <= MAX_US
    assert {MIN_US, MAX_US} <= set(positions_us(weights, np.ones(52) * 10))
