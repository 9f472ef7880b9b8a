"""deploy/board: the systemd unit's command is a real facesynth command on the board's graph."""

from __future__ import annotations

import shlex
from pathlib import Path

from facesynth.app.cli import build_parser
from facesynth.app.graph import load_graph
from facesynth.app.nodes import stage_of

BOARD = Path(__file__).resolve().parents[2] / "deploy" / "board"
UNIT = BOARD / "facesynth-control.service"


def unit_settings(path: Path = UNIT) -> dict[str, list[str]]:
    """Every ``Key=value`` of a unit file, by key (comments and sections left out)."""
    settings: dict[str, list[str]] = {}
    for raw in path.read_text().splitlines():
        line = raw.strip()
        if line and not line.startswith(("#", ";", "[")):
            key, _, value = line.partition("=")
            settings.setdefault(key.strip(), []).append(value.strip())
    return settings


def test_the_unit_restarts_on_failure_and_runs_as_its_own_user() -> None:
    settings = unit_settings()
    assert settings["Restart"] == ["on-failure"]
    assert settings["User"] == ["facesynth"]
    assert settings["StartLimitIntervalSec"] == ["0"]
    assert settings["WantedBy"] == ["multi-user.target"]


def test_exec_start_parses_with_the_real_cli_on_the_shipped_graph() -> None:
    argv = shlex.split(unit_settings()["ExecStart"][0])
    assert argv[0] == "/opt/facesynth/bin/facesynth"
    args = build_parser().parse_args(argv[1:])
    assert args.command == "control"
    graph = load_graph(BOARD / Path(args.graph).name)
    assert stage_of(graph.nodes[args.node]) == "control"
    assert args.zenoh_config == "/etc/facesynth/certs/control.json5"
    assert Path(args.graph).parent == Path("/etc/facesynth")
