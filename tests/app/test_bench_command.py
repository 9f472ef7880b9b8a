"""``facesynth bench``'s command: an option a benchmark does not read is refused, not ignored."""

from __future__ import annotations

import argparse

import pytest

from facesynth.app.bench.arguments import add_bench_arguments
from facesynth.app.cli import main


def _kinds() -> list[str]:
    parser = argparse.ArgumentParser()
    add_bench_arguments(parser)
    (what,) = [action for action in parser._actions if action.dest == "what"]
    assert what.choices is not None
    return sorted(what.choices)


@pytest.mark.parametrize("kind", [k for k in _kinds() if k != "robot"])
def test_every_benchmark_but_robot_refuses_a_calibration(
    kind: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # Refused before the name is looked up or anything runs: one line, whatever the kind.
    assert main(["bench", kind, "--calibration", "alice"]) == 2
    err = capsys.readouterr().err
    assert f"facesynth bench: error: --calibration: bench {kind} does not read it (" in err
    assert "bench robot does" in err
    assert len(err.strip().splitlines()) == 1


def test_bench_robot_reads_the_calibration(capsys: pytest.CaptureFixture[str]) -> None:
    # Not refused: looked up (and not found) as bench robot's performer calibration.
    assert main(["bench", "robot", "--calibration", "/nonexistent/alice.json"]) == 2
    err = capsys.readouterr().err
    assert "--calibration: calibration file /nonexistent/alice.json does not exist" in err
    assert "does not read it" not in err
