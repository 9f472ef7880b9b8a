"""docker-compose.yml and deploy/ stay consistent with the graph, the CLI and Zenoh's parser."""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Annotated

import msgspec
import pytest
import yaml
import zenoh

from facesynth.app.cli import build_parser
from facesynth.app.compose import compose_file, override_file, secure_file
from facesynth.app.graph import load_graph
from facesynth.app.nodes import stage_of
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.base import ServoDriver
from facesynth.services.control.drivers.registry import DRIVERS

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


def test_the_images_run_every_command_as_the_clones_owner() -> None:
    """The entry point and the health check go through facesynth.app.container_user, and what
    the control service records goes to ./recordings, a folder of the clone (not one the
    engine would make, owned by root)."""
    text = (ROOT / "Dockerfile").read_text()
    entry = '["python", "-m", "facesynth.app.container_user"'
    assert f"ENTRYPOINT {entry}]" in text
    assert f'CMD {entry}, "health"]' in text
    assert "\nUSER " not in text, "root at start, only to step down to the clone's owner"
    assert "./recordings:/recordings" in SERVICES["control"]["volumes"]
    assert (ROOT / "recordings" / ".gitignore").is_file()


def test_secure_override_is_generated_from_the_graph() -> None:
    generated = secure_file(GRAPH, "deploy/graph.toml")
    assert (ROOT / "docker-compose.secure.yml").read_text() == generated, (
        "docker-compose.secure.yml is stale: run facesynth compose deploy/graph.toml --secure "
        "--out docker-compose.secure.yml"
    )
    secure = yaml.safe_load(generated)["services"]
    assert set(secure) == set(SERVICES)
    for name, service in secure.items():
        if name == "router":
            config = service["command"][service["command"].index("--zenoh-config") + 1]
        else:
            config = service["environment"]["ZENOH_CONFIG"]
            assert Path(config).stem == stage_of(GRAPH.nodes[name])
        assert (ROOT / "deploy" / "secure" / Path(config).name).is_file()
        assert service["volumes"] == ["./certs:/etc/facesynth-certs:ro"]


def test_secure_override_needs_the_rig_of_deploy_secure() -> None:
    other = load_graph(ROOT / "deploy" / "graph.toml")
    other.rig = "lab"
    with pytest.raises(ValueError, match="deploy/secure is written for rig 'default'"):
        secure_file(other, "g.toml")


def test_tracker_stages_use_the_full_image_and_the_rest_the_board_image() -> None:
    images = {name: service["image"] for name, service in SERVICES.items()}
    assert images == {
        "router": "facesynth-board:latest",
        "sensor": "facesynth:latest",
        "points": "facesynth:latest",
        "features": "facesynth-board:latest",
        "translator": "facesynth-board:latest",
        "control": "facesynth-board:latest",
    }
    extras = {s["image"]: s["build"]["args"]["EXTRAS"] for s in SERVICES.values()}
    assert extras == {"facesynth:latest": "chain", "facesynth-board:latest": "fast,face"}
    for service in SERVICES.values():
        assert "user" not in service, "the image runs each command as the clone's owner"
    health = SERVICES["router"]["healthcheck"]["test"]
    assert health[:2] == ["CMD", "facesynth"] and build_parser().parse_args(health[2:]).router


class PortConfig(
    msgspec.Struct, tag="porty", tag_field="driver", kw_only=True, forbid_unknown_fields=True
):
    """A test driver naming a serial device."""

    port: Annotated[str, msgspec.Meta(description="serial device")]
    log: Annotated[str, msgspec.Meta(description="log file")] = "/recordings/porty.jsonl"


class PortDriver(ServoDriver):
    def __init__(self, config: PortConfig, profile: object) -> None:
        pass

    async def connect(self) -> None:
        pass

    async def send(self, positions: Mapping[str, float], info: CommandInfo) -> None:
        pass

    async def close(self) -> None:
        pass


@pytest.fixture
def port_driver() -> Iterator[None]:
    DRIVERS.register(PortConfig)(PortDriver)
    yield
    DRIVERS.unregister("porty")


def test_a_controller_override_passes_its_device_through(port_driver: None, tmp_path: Path) -> None:
    folder = tmp_path / "deploy" / "controllers"
    folder.mkdir(parents=True)
    graph_file = folder / "serial.toml"
    graph_file.write_text(
        '[nodes.control]\nstage = "control"\nprofile = "paper16"\n'
        'driver = { driver = "porty", port = "/dev/ttyACM0" }\n'
    )
    # the graph lies under a folder named deploy: the containers see it under /etc/facesynth
    text = override_file(load_graph(graph_file), str(graph_file))
    control = yaml.safe_load(text)["services"]["control"]
    assert control["command"] == [
        "control",
        "--graph",
        "/etc/facesynth/controllers/serial.toml",
        "--node",
        "control",
    ]
    assert control["devices"] == ["/dev/ttyACM0:/dev/ttyACM0"]
    assert control["group_add"] == ["${FACESYNTH_DEVICE_GID:-20}"]
    assert control["volumes"] == ["./deploy:/etc/facesynth:ro", "./recordings:/recordings"]
    assert "build" not in control and "image" not in control


def test_a_node_called_router_is_refused() -> None:
    graph = load_graph(ROOT / "deploy" / "graph.toml")
    graph.nodes["router"] = graph.nodes.pop("features")
    with pytest.raises(ValueError, match="may not be called 'router'"):
        compose_file(graph, "g.toml")


@pytest.mark.parametrize(
    "graph_file", sorted((ROOT / "deploy" / "controllers").glob("*.toml")), ids=lambda p: p.stem
)
def test_controller_overrides_are_generated_from_their_graphs(graph_file: Path) -> None:
    relative = graph_file.relative_to(ROOT).as_posix()
    generated = override_file(load_graph(graph_file), relative)
    target = ROOT / f"docker-compose.{graph_file.stem}.yml"
    assert target.is_file() and target.read_text() == generated, (
        f"{target.name} is stale: run facesynth compose {relative} --override --out {target.name}"
    )
    for name, service in yaml.safe_load(generated)["services"].items():
        assert name in SERVICES, "an override replaces services of the main compose file"
        args = build_parser().parse_args(service["command"])
        assert args.graph == f"/etc/facesynth/controllers/{graph_file.name}"


def test_a_server_on_every_interface_is_published_on_the_hosts_loopback() -> None:
    virtual = yaml.safe_load((ROOT / "docker-compose.virtual.yml").read_text())["services"]
    assert virtual["control"]["ports"] == ["127.0.0.1:${FACESYNTH_PORT_8080:-8080}:8080"]


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
