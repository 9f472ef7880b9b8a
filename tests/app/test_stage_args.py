"""facesynth.app.stage_args: a stage's flags over a graph node, for one stage or a whole run."""

from __future__ import annotations

import pytest

from facesynth.app.cli import build_parser
from facesynth.app.graph import parse_graph
from facesynth.app.nodes import ControlNode, TranslatorNode
from facesynth.app.stage_args import apply_arguments
from facesynth.services.control.drivers.record import RecordConfig
from facesynth.services.sensor.sources.video import VideoConfig

GRAPH = parse_graph(
    {
        "nodes": {
            "sensor": {"stage": "sensor", "source": {"source": "video", "path": "a.mp4"}},
            "head": {"stage": "translator", "profile": "paper16", "queue": 4},
            "face": {"stage": "translator", "profile": "virtual"},
            "rec": {"stage": "control", "driver": {"driver": "record"}, "watchdog": 0.2},
        }
    },
    plugins=False,
)


def test_flags_complete_and_override_a_node() -> None:
    args = build_parser().parse_args(["control", "--out", "x.jsonl", "--watchdog", "0.3"])
    node, config = apply_arguments("rec", GRAPH.nodes["rec"], args)
    assert config == RecordConfig(out="x.jsonl")
    assert node == ControlNode(driver={"driver": "record", "out": "x.jsonl"}, watchdog=0.3)


def test_without_flags_the_node_is_kept() -> None:
    args = build_parser().parse_args(["sensor"])
    node, config = apply_arguments("sensor", GRAPH.nodes["sensor"], args)
    assert config == VideoConfig(path="a.mp4")
    assert node.source == {"source": "video", "path": "a.mp4", "loop": False, "fps": None}


@pytest.mark.parametrize("name", ["head", "face"])
def test_a_run_flag_applies_to_every_node_of_its_stage(name: str) -> None:
    args = build_parser().parse_args(["run", "--mirror", "--queue", "3"])
    node, config = apply_arguments(name, GRAPH.nodes[name], args)
    assert config is None
    assert node == TranslatorNode(profile=GRAPH.nodes[name].profile, mirror=True, queue=3)


def test_a_selecting_flag_switches_the_plugin() -> None:
    args = build_parser().parse_args(["sensor", "--ticks", "5"])
    node, _ = apply_arguments("sensor", GRAPH.nodes["sensor"], args)
    assert node.source == {"source": "ticks", "count": 5, "fps": None}
