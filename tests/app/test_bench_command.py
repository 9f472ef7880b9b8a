"""``facesynth bench``'s command: an option a benchmark does not read is refused, not ignored."""

from __future__ import annotations

import argparse
import re

import pytest

from facesynth.app.bench.arguments import READERS, RIG, add_bench_arguments, unread_options
from facesynth.app.cli import main
from facesynth.app.stage_args import PLUGIN_FLAGS


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


def _rig_flags(stage: str) -> set[str]:
    flags = PLUGIN_FLAGS[stage][0]
    return {flags.selector, flags.config_file or flags.selector} | {f.flag for f in flags.flags()}


def _options() -> list[argparse.Action]:
    """bench's own options (the robot's rig flags come from the plugin registries: below)."""
    parser = argparse.ArgumentParser()
    add_bench_arguments(parser)
    rig = {flag for stage in RIG for flag in _rig_flags(stage)}
    return [
        action
        for action in parser._actions
        if action.dest not in ("help", "what") and not rig & set(action.option_strings)
    ]


def test_every_option_names_the_benchmarks_that_read_it_in_its_help() -> None:
    kinds = set(_kinds())
    for action in _options():
        readers = READERS[action.dest]  # every option has its readers
        assert readers <= kinds, action.dest
        help_text = action.help or ""
        if action.dest != "video":  # "video" is every benchmark's that plays one
            missing = [k for k in readers if not re.search(rf"\b{k}\b", help_text)]
            assert not missing, f"{action.dest}'s help does not name {missing}: {help_text}"
            # and a benchmark its help names before a colon reads it
            named = {
                word
                for clause in help_text.split(";")
                if ":" in clause
                for word in re.split(r"[,\s]+", clause.split(":", 1)[0].strip())
                if word in kinds
            }
            assert named <= readers, f"{action.dest}: {sorted(named - readers)} named, not read"


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["chain", "--head", "simhead16"], "--head: bench chain does not read it"),
        (
            ["face", "--frames", "3"],
            "--frames: bench face does not read it (bench drivers, robot, run, tracker do)",
        ),
        (["tracker", "--hops"], "--hops: bench tracker does not read it (bench chain does)"),
        (["recording", "--profile", "head16"], "--profile: bench recording does not read it"),
        (["smoothing", "--fps", "60"], "--fps: bench smoothing does not read it"),
    ],
)
def test_an_option_the_benchmark_does_not_read_is_refused(
    argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["bench", *argv]) == 2
    err = capsys.readouterr().err
    assert f"facesynth bench: error: {message}" in err and len(err.strip().splitlines()) == 1


def test_options_left_at_their_defaults_are_not_refused() -> None:
    parser = argparse.ArgumentParser()
    add_bench_arguments(parser)
    for kind in _kinds():
        assert unread_options(parser.parse_args([kind])) == [], kind


@pytest.mark.parametrize(
    "rig",
    [
        ["--driver", "dynamixel"],
        ["--port", "/dev/ttyUSB0"],
        ["--i2c-bus", "1"],
        ["--camera", "0"],
        ["--ros2-image-topic", "/head/image_raw"],
    ],
)
def test_the_robots_rig_flags_are_bench_robots_alone(
    rig: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    # Declared from the plugin registries, not in READERS: refused all the same elsewhere.
    assert main(["bench", "tracker", *rig]) == 2
    err = capsys.readouterr().err
    assert (
        f"facesynth bench: error: {rig[0]}: bench tracker does not read it (bench robot does)"
        in err
    )


def test_bench_keeps_its_own_options_where_a_plugin_has_the_same_flag() -> None:
    # --fps is the camera source's frame rate too: on bench it stays chain's and the others'.
    parser = argparse.ArgumentParser()
    add_bench_arguments(parser)
    (fps,) = [action for action in parser._actions if "--fps" in action.option_strings]
    assert fps.dest == "fps" and fps.default == 30.0
