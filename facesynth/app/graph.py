"""The chain, described once, as data: a graph file lists the nodes of a rig.

::

    rig = "default"

    [nodes.sensor]
    stage = "sensor"
    source = { source = "video" }          # the bundled performer video

    [nodes.control]
    stage = "control"
    profile = "paper16"
    driver = { driver = "record", out = "facesynth-commands.jsonl" }

Each ``[nodes.NAME]`` table is one stage's options (:mod:`facesynth.app.nodes`); plugin tables
(``source``, ``backend``, ``driver``) are checked against their registries when the graph is
loaded. ``facesynth run GRAPH`` runs every node in one process; ``facesynth STAGE --graph GRAPH
[--node NAME]`` runs one node as its own service; ``facesynth compose GRAPH`` writes the
docker-compose file that runs each node in a container. Command-line flags override the file.
"""

from __future__ import annotations

import difflib
import tomllib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import msgspec

from facesynth.app.nodes import PLUGIN_FIELDS, Node, stage_of
from facesynth.app.stages.registry import STAGES
from facesynth.app.toml_text import toml_value
from facesynth.runtime import keys
from facesynth.runtime.oneline import one_line
from facesynth.runtime.plugins import PluginError, Registry

GRAPHS_DIR = Path(__file__).parent / "graphs"
#: The graph ``facesynth run`` runs without one: the demo.
DEFAULT_GRAPH = GRAPHS_DIR / "demo.toml"

#: The plugin table of each stage that has one, and its registry (read from the stages).
PLUGIN_TABLES: dict[str, tuple[str, Registry[Any]]] = {
    stage.name: (stage.plugin.field, stage.plugin.registry)
    for stage in STAGES
    if stage.plugin is not None
}


class GraphError(ValueError):
    """A graph file that cannot be used; the message names the file and the node (on one
    line, whatever the file's keys hold)."""

    def __init__(self, message: str) -> None:
        super().__init__(one_line(message))


class Graph(msgspec.Struct, kw_only=True, forbid_unknown_fields=True):
    """A rig's chain: its nodes by name."""

    rig: str = "default"
    description: str = ""
    nodes: dict[str, Node]

    def of_stage(self, stage: str) -> dict[str, Any]:
        """The nodes running ``stage``, by name."""
        return {name: node for name, node in self.nodes.items() if stage_of(node) == stage}

    def of_stages(self, stages: tuple[str, ...]) -> dict[str, Any]:
        """The nodes running any of ``stages``, by name."""
        return {name: node for name, node in self.nodes.items() if stage_of(node) in stages}

    def sources(self) -> dict[str, Any]:
        """The nodes whose stage consumes nothing (the chain's input: its sensors), by name."""
        return self.of_stages(STAGES.sources())


def plugin_config(node: Any, where: str) -> msgspec.Struct | None:
    """A node's plugin config (source, backend or driver) validated by its registry."""
    table = STAGES.of(node).plugin
    if table is None:
        return None
    try:
        return table.registry.parse(getattr(node, table.field), where)
    except PluginError as exc:
        raise GraphError(str(exc)) from None


def check_node(name: str, node: Any, where: str) -> None:
    """Check a node's name and its robot's (they become parts of keys), and that the services
    a sensor waits for are stages (a misspelt one would be waited for in vain)."""
    try:
        keys.check_name(name, "node")
        robot = getattr(node, "robot", None)
        if robot is not None:
            keys.check_name(robot, "robot")
    except keys.KeyNameError as exc:
        raise GraphError(f"{where}: node {name}: {exc}") from None
    problem = wait_for_problem(getattr(node, "wait_for", None) or ())
    if problem:
        raise GraphError(f"{where}: node {name}: {problem}")


def wait_for_problem(services: Sequence[str]) -> str | None:
    """Why a ``--wait-for`` list names a service that never comes (not a stage), or None."""
    stages = STAGES.names()
    for service in services:
        if service not in stages:
            close = difflib.get_close_matches(service, stages, n=1)
            hint = f"did you mean {close[0]}? " if close else ""
            return f"--wait-for: no service {service!r} ({hint}services: {', '.join(stages)})"
    return None


def check_graph(graph: Graph, where: str, *, plugins: bool = True) -> Graph:
    """Check names and (unless ``plugins`` is false) plugin tables; returns ``graph``."""
    if not graph.nodes:
        raise GraphError(f"{where}: a graph needs at least one node")
    try:
        keys.check_name(graph.rig)
    except keys.KeyNameError as exc:
        raise GraphError(f"{where}: {exc}") from None
    for name, node in graph.nodes.items():
        check_node(name, node, where)
    if plugins:
        for name, node in graph.nodes.items():
            plugin_config(node, f"{where}: node {name}")
    return graph


class _GraphFile(msgspec.Struct, kw_only=True, forbid_unknown_fields=True):
    """A graph file before its nodes are read (so errors can name the node)."""

    rig: str = "default"
    description: str = ""
    nodes: dict[str, dict[str, Any]]


def parse_graph(data: Mapping[str, Any], where: str = "<graph>", *, plugins: bool = True) -> Graph:
    """A graph from a parsed TOML mapping; ``plugins=False`` leaves the plugin tables unchecked
    (command-line flags may still complete them: the CLI checks them after applying its flags)."""
    try:
        raw = msgspec.convert(dict(data), _GraphFile)
    except msgspec.ValidationError as exc:
        raise GraphError(f"{where}: {_located(str(exc))}") from None
    nodes = {}
    node_types = STAGES.node_union()
    for name, table in raw.nodes.items():
        stage = table.get("stage")
        if isinstance(stage, str) and stage not in STAGES:
            raise GraphError(
                f"{where}: node {name}: unknown stage {stage!r} "
                f"(stages: {', '.join(STAGES.names())})"
            )
        try:
            nodes[name] = msgspec.convert(table, node_types)
        except msgspec.ValidationError as exc:
            raise GraphError(f"{where}: node {name}: {_located(str(exc))}") from None
    graph = Graph(rig=raw.rig, description=raw.description, nodes=nodes)
    return check_graph(graph, where, plugins=plugins)


def _located(message: str) -> str:
    """``… - at `$.watchdog``` → ``watchdog: …``."""
    text, sep, path = message.partition(" - at `$.")
    return f"{path.rstrip('`')}: {text}" if sep else message


def bundled_graphs() -> dict[str, str]:
    """The graphs shipped with facesynth (``facesynth/app/graphs``): name -> description."""
    out = {}
    for file in sorted(GRAPHS_DIR.glob("*.toml")):
        try:
            description = tomllib.loads(file.read_text(encoding="utf-8")).get("description", "")
        except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
            description = ""
        out[file.stem] = str(description)
    return out


def graph_help() -> str:
    """The help of a GRAPH argument: a file, or a bundled graph's name (each listed)."""
    names = "; ".join(
        f"{name}: {text}" if text else name for name, text in bundled_graphs().items()
    )
    return f"graph file, or a bundled graph by name ({names}); default: demo"


def graph_file(path: str | Path | None) -> Path:
    """The file of a graph argument: a path as given, else a bundled graph of that name
    (``face`` or ``face.toml``, from any folder; a file of that name here comes first), else
    the demo graph when none is given."""
    if path is None:
        return DEFAULT_GRAPH
    file = Path(path)
    if not file.exists() and len(file.parts) == 1:
        bundled = GRAPHS_DIR / f"{file.name.removesuffix('.toml')}.toml"
        if bundled.is_file():
            return bundled
    return file


def load_graph(path: str | Path | None = None, *, plugins: bool = True) -> Graph:
    """The graph in ``path`` (a TOML file or a bundled graph's name: :func:`graph_file`), or
    the demo graph (see :func:`parse_graph`)."""
    file = graph_file(path)
    try:
        text = file.read_text(encoding="utf-8")
    except FileNotFoundError:
        bundled = ", ".join(bundled_graphs())
        raise GraphError(f"graph {file} does not exist (bundled graphs: {bundled})") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise GraphError(f"cannot read graph {file}: {exc}") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise GraphError(f"{file}: not valid TOML: {exc}") from None
    return parse_graph(data, str(file), plugins=plugins)


def select_node(graph: Graph, stage: str, name: str | None, where: str) -> Any:
    """The node to run as ``stage``: the one named, or the graph's only node of that stage."""
    if name is not None:
        node = graph.nodes.get(name)
        if node is None:
            raise GraphError(f"{where}: no node {name!r} (nodes: {', '.join(graph.nodes)})")
        if stage_of(node) != stage:
            raise GraphError(f"{where}: node {name!r} runs {stage_of(node)}, not {stage}")
        return node
    nodes = graph.of_stage(stage)
    if len(nodes) != 1:
        found = ", ".join(nodes) or "none"
        raise GraphError(f"{where}: name the {stage} node with --node (nodes of {stage}: {found})")
    return next(iter(nodes.values()))


def _toml(value: Any) -> str:
    """One value of a graph file: inline tables with bare keys, their ``None`` entries left out."""
    return toml_value(value, bare_keys=True, skip_none=True)


def graph_to_toml(graph: Graph) -> str:
    """A graph as TOML text (as :func:`load_graph` reads it)."""
    lines = [f"rig = {_toml(graph.rig)}"]
    if graph.description:
        lines.append(f"description = {_toml(graph.description)}")
    for name, node in graph.nodes.items():
        lines.extend(("", f"[nodes.{name}]"))
        data = msgspec.to_builtins(node)
        default = msgspec.to_builtins(STAGES.of(node).node())
        for key, value in data.items():
            if value is not None and (
                key in ("stage", *PLUGIN_FIELDS) or value != default.get(key)
            ):
                lines.append(f"{key} = {_toml(value)}")
    return "\n".join(lines) + "\n"
