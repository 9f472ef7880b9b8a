"""docker-compose.yml and deploy/ stay consistent with the graph, the CLI and Zenoh's parser."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
import zenoh

from facesynth.app.cli import build_parser
from facesynth.app.compose import compose_file
from facesynth.app.graph import load_graph
from facesynth.app.nodes import stage_of

ROOT = Path(__file__).resolve().parents[2]
COMPOSE = yaml.safe_load((ROOT / "docker-compose.yml").read_text())
SERVICES = COMPOSE["services"]
GRAPH = load_graph(ROOT / "deploy" / "graph.toml")


def test_compose_file_is_generated_from_the_graph() -> None:
    generated = compose_file(GRAPH, "deploy/graph.toml", graph_path="/etc/facesynth/graph.toml")
    assert (ROOT / "docker-compose.yml").read_text() == generated, (
        "docker-compose.yml is stale: run facesynth compose deploy/graph.toml --out "
        "docker-compose.yml"
    )


@pytest.mark.parametrize("name", sorted(set(SERVICES) - {"router"}))
def test_every_compose_service_runs_a_node_of_the_graph(name: str) -> None:
    command = SERVICES[name]["command"]
    node = GRAPH.nodes[command[command.index("--node") + 1]]
    assert command[0] == stage_of(node)
    assert command[command.index("--graph") + 1] == "/etc/facesynth/graph.toml"


def test_compose_runs_router_and_the_five_stages() -> None:
    commands = {name: service["command"][0] for name, service in SERVICES.items()}
    assert commands == {
        "router": "router",
        "sensor": "sensor",
        "points": "points",
        "features": "features",
        "translator": "translator",
        "control": "control",
    }


@pytest.mark.parametrize("name", sorted(SERVICES))
def test_every_compose_command_parses(name: str) -> None:
    args = build_parser().parse_args(SERVICES[name]["command"])
    assert args.command == SERVICES[name]["command"][0]


@pytest.mark.parametrize("name", sorted(SERVICES))
def test_zenoh_config_files_exist_in_deploy(name: str) -> None:
    service = SERVICES[name]
    mounted = {v.split(":")[1]: v.split(":")[0] for v in service.get("volumes", [])}
    assert mounted.get("/etc/facesynth") == "./deploy"
    files = [service.get("environment", {}).get("ZENOH_CONFIG")]
    command = service["command"]
    if "--zenoh-config" in command:
        files.append(command[command.index("--zenoh-config") + 1])
    for path in filter(None, files):
        assert path.startswith("/etc/facesynth/")
        assert (ROOT / "deploy" / Path(path).name).is_file(), path


@pytest.mark.parametrize("path", sorted((ROOT / "deploy").glob("*.json5")), ids=lambda p: p.name)
def test_deploy_configs_load_in_zenoh(path: Path) -> None:
    config = zenoh.Config.from_file(str(path))
    assert config.get_json("scouting/multicast/enabled") == "false"


def test_dockerfile_takes_base_image_as_build_argument() -> None:
    text = (ROOT / "Dockerfile").read_text()
    assert text.splitlines()[0].startswith("#")
    assert "ARG BASE_IMAGE" in text and "FROM ${BASE_IMAGE}" in text
    build_args = {s["build"]["args"]["BASE_IMAGE"] for s in SERVICES.values() if "build" in s}
    assert build_args == {"${FACESYNTH_BASE_IMAGE:-python:3.11-slim}"}


def test_a_node_asking_for_priority_gets_the_capability_in_its_container() -> None:
    from facesynth.app.graph import parse_graph

    graph = parse_graph(
        {
            "nodes": {
                "points": {"stage": "points", "realtime": 20},
                "features": {"stage": "features", "nice": -5},
                "translator": {"stage": "translator", "nice": 5},
            }
        }
    )
    text = compose_file(graph, "g.toml", graph_path="/etc/facesynth/graph.toml")
    blocks = {block.split(":")[0].strip(): block for block in text.split("\n\n  ")[1:]}
    assert "cap_add: [SYS_NICE]" in blocks["points"]
    assert "cap_add: [SYS_NICE]" in blocks["features"]
    assert "cap_add" not in blocks["translator"]
