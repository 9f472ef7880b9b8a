"""Stages are registered like plugins (issue #28): each exports a descriptor (node struct, build
function, consumed and produced keys), and the graph, the CLI and the runner read them.

A stage defined in this file alone parses in a graph, gets its flags, is built by ``build_node``,
runs in ``facesynth run``'s chain and has its own command (``facesynth gauge``), with no edit
elsewhere.
"""

from __future__ import annotations

import argparse
import importlib
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Annotated

import msgspec
import pytest

from facesynth.app.cli import build_parser, main
from facesynth.app.data import sample_openface_csv
from facesynth.app.graph import GraphError, parse_graph
from facesynth.app.stage_args import apply_arguments, node_flags
from facesynth.app.stages.descriptor import NodeBuild, StageDescriptor, StageParts
from facesynth.app.stages.node import StageNode
from facesynth.app.stages.registry import STAGES, StageRegistry, UnknownStage
from facesynth.app.wiring import build_node
from facesynth.runtime import keys
from facesynth.runtime.service import ServiceContext
from facesynth.schemas.messages import Features

#: What the gauge nodes counted, by node name.
COUNTED: dict[str, int] = {}


class GaugeNode(StageNode, tag="gauge"):
    """Count the features on ``…/features`` (a sink known only to this test file)."""

    every: Annotated[int, msgspec.Meta(ge=1, description="log every N features")] = 10


def build_gauge(request: NodeBuild) -> StageParts:
    node: GaugeNode = request.node
    COUNTED[request.name] = 0

    async def serve(ctx: ServiceContext) -> None:
        subscription = ctx.subscribe("features", 64, Features)
        ctx.ready()
        async for _ in subscription:
            COUNTED[request.name] += 1
            if COUNTED[request.name] % node.every == 0:
                ctx.log.info("%d features", COUNTED[request.name])

    return StageParts(request.name, "gauge", serve, node)


GAUGE = StageDescriptor(
    name="gauge",
    node=GaugeNode,
    build=build_gauge,
    consumes="features",
    produces=None,
    help="count the features",
)


@pytest.fixture
def gauge() -> Iterator[StageDescriptor]:
    # Registered after the stage commands' module was imported, as a plugin found late is.
    importlib.import_module("facesynth.app.commands.stage")
    STAGES.register(GAUGE)
    yield GAUGE
    STAGES.unregister("gauge")


def test_the_chain_order_follows_what_each_stage_consumes() -> None:
    assert STAGES.names() == keys.SERVICES
    for stage in STAGES:
        assert (stage.consumes, stage.produces) == (
            keys.CONSUMES[stage.name],
            keys.PUBLISHES[stage.name],
        )
        assert stage.node.__struct_config__.tag == stage.name


def test_a_stage_of_a_test_file_parses_builds_and_has_flags(gauge: StageDescriptor) -> None:
    assert STAGES.names() == ("sensor", "points", "features", "gauge", "translator", "control")
    graph = parse_graph({"nodes": {"g": {"stage": "gauge", "every": 5}}})
    node = graph.nodes["g"]
    assert isinstance(node, GaugeNode) and node.every == 5
    parts = build_node("g", node, graph)
    assert (parts.name, parts.stage, parts.service) == ("g", "gauge", node)
    assert "every" in [flag.field for flag in node_flags("gauge")]


def test_a_stage_of_a_test_file_runs_in_a_chain(
    gauge: StageDescriptor, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    graph = tmp_path / "g.toml"
    csv = sample_openface_csv()
    graph.write_text(
        f"""
[nodes.sensor]
stage = "sensor"
fast = true
[nodes.points]
stage = "points"
backend = {{ backend = "openface", csv = "{csv}" }}
[nodes.features]
stage = "features"
[nodes.counter]
stage = "gauge"
[nodes.translator]
stage = "translator"
[nodes.control]
stage = "control"
driver = {{ driver = "record", out = "{tmp_path / "out.jsonl"}" }}
"""
    )
    assert main(["run", str(graph), "--listen", "tcp/127.0.0.1:0"]) == 0
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert summary["frames"] == 100 and summary["commands"] > 0
    assert COUNTED["counter"] > 0


def _commands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def test_a_stage_of_a_test_file_gets_its_own_command(gauge: StageDescriptor) -> None:
    from facesynth.app.commands.stage import cmd_stage

    parser = build_parser()
    commands = _commands(parser)
    assert list(commands)[1:7] == list(STAGES.names())
    assert "count the features" in commands["gauge"].format_help()
    args = parser.parse_args(["gauge", "--every", "5", "--graph", "g.toml", "--node", "g"])
    assert (args.handler, args.stage, args.graph, args.node) == (cmd_stage, "gauge", "g.toml", "g")
    node, _ = apply_arguments("g", GaugeNode(), args)
    assert isinstance(node, GaugeNode) and node.every == 5


def test_an_unregistered_stage_has_no_command() -> None:
    assert "gauge" not in STAGES.names()
    assert "gauge" not in _commands(build_parser())


def test_an_unknown_stage_names_the_registered_ones(gauge: StageDescriptor) -> None:
    with pytest.raises(GraphError, match=r"unknown stage 'gauges' \(stages: sensor, .*gauge"):
        parse_graph({"nodes": {"x": {"stage": "gauges"}}})
    with pytest.raises(UnknownStage, match=r"did you mean gauge\?"):
        STAGES.get("gauges")


def test_a_stage_registered_twice_or_mistagged_is_refused() -> None:
    registry = StageRegistry("facesynth.app.stages")
    registry.register(GAUGE)
    registry.register(GAUGE)  # the same descriptor again: no change
    with pytest.raises(ValueError, match="stage 'gauge' is registered twice"):
        registry.register(
            StageDescriptor("gauge", GaugeNode, build_gauge, "features", None, "again")
        )
    with pytest.raises(TypeError, match="its node struct is tagged 'gauge'"):
        StageDescriptor("meter", GaugeNode, build_gauge, "features", None, "mistagged")
