"""``facesynth doctor``: the graph ``run`` would run, what it needs, and one line per missing
piece; exit 0 when it can run here, 2 otherwise."""

from __future__ import annotations

from pathlib import Path

import pytest

from facesynth.app.cli import build_parser, main
from facesynth.app.doctor.command import router_need
from facesynth.app.doctor.needs import SerialNeed, graph_needs
from facesynth.app.graph import load_graph
from facesynth.app.profile_choice import settle_profiles
from facesynth.app.stage_args import apply_arguments

QUIET = ["--listen", "tcp/127.0.0.1:0", "--log-level", "WARNING"]


def needs_of(*argv: str):  # type: ignore[no-untyped-def]
    args = build_parser().parse_args(["doctor", *argv])
    graph = load_graph(args.graph, plugins=False)
    configs = {}
    for name, node in list(graph.nodes.items()):
        graph.nodes[name], configs[name] = apply_arguments(name, node, args)
    settle_profiles(graph, configs, check=False)
    return graph_needs(graph, configs, router=router_need(args), options=args)


def test_what_the_demo_needs() -> None:
    needs = needs_of()
    assert needs.cameras == [] and needs.serial == []
    assert needs.outputs == [
        ("control node control's record file", Path("facesynth-commands.jsonl"))
    ]
    assert needs.profiles == [
        ("translator", "paper16", None),
        ("control", "paper16", needs.profiles[1][2]),
    ]
    assert set(needs.extras) == {"tracker"}  # the video source and the tracker
    assert needs.router is not None and needs.router.embedded
    assert needs.router.options.listen == ["tcp/127.0.0.1:7447"]


def test_what_a_camera_board_and_recording_need(tmp_path: Path) -> None:
    needs = needs_of(
        "face", "--camera", "http://cam:8090/camera.mjpg", "--driver", "arduino",
        "--port", "/dev/ttyACM0", "--record", str(tmp_path / "s.mcap"), "--calibration", "me",
        "--mode", "client", "--connect", "tcp/10.0.0.2:7447",
    )  # fmt: skip
    assert needs.cameras == [("sensor", "http://cam:8090/camera.mjpg")]
    assert needs.serial == [SerialNeed("page", "arduino", "/dev/ttyACM0", 115200)]
    assert ("--record session", tmp_path / "s.mcap") in needs.outputs
    assert needs.calibrations == [("features", "me"), ("translator", "me")]
    assert needs.extras["record"] == ["--record"]
    assert needs.router is not None and not needs.router.embedded


def test_a_maestro_detecting_its_baud_rate_is_asked_so() -> None:
    needs = needs_of("--driver", "maestro", "--port", "/dev/ttyAMA0", "--maestro-detect-baud")
    assert needs.serial == [SerialNeed("control", "maestro", "/dev/ttyAMA0", 115200, True)]


def test_the_vmc_driver_needs_the_face_extra_and_its_profile() -> None:
    needs = needs_of("--driver", "vmc")
    assert needs.extras["face"] == ["control node control (vmc)"]
    assert [(node, name) for node, name, _ in needs.profiles] == [
        ("translator", "arkit52"),
        ("control", "arkit52"),
    ]


def test_each_missing_piece_is_one_line_then_the_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    blocker = tmp_path / "not-a-folder"
    blocker.write_text("x")
    argv = ["doctor", "--driver", "vmc", "--profile", "paper16", "--calibration", "nobody",
            "--record", str(blocker / "s.mcap"), *QUIET]  # fmt: skip
    assert main(argv) == 2
    captured = capsys.readouterr()
    fixes = [" ".join(line.split()) for line in captured.out.splitlines() if line.startswith("fix")]
    assert [line.split(":")[0] for line in fixes] == [
        f"fix folder {blocker / 's.mcap'}",
        "fix profile paper16 (node control)",
        "fix calibration nobody (node features)",
        "fix calibration nobody (node translator)",
    ]
    assert "choose --profile arkit52 or virtual or virtual_bs" in fixes[1]
    assert "facesynth calibrate nobody" in fixes[2]
    err = captured.err.strip().splitlines()
    assert err[-1].startswith("facesynth doctor: error: graph demo cannot run on this host: 4 ")
    assert "Traceback" not in captured.err


def test_a_graph_that_can_run_exits_0(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["doctor", "face", "--http", "127.0.0.1:0", *QUIET]) == 0
    out = capsys.readouterr().out.splitlines()
    assert not [line for line in out if line.startswith("fix")]
    assert " ".join(out[-1].split()).startswith("graph face can run on this host (")
    profiles = [" ".join(line.split()) for line in out if line.split()[1:2] == ["profile"]]
    assert profiles == [
        "ok profile virtual (node translator): loads, 17 controls",
        "ok profile virtual (node page): loads, 17 controls",
    ]
