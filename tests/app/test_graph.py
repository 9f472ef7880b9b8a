"""facesynth.app.graph: graph files, their errors, node selection, writing a graph back."""

from __future__ import annotations

from pathlib import Path

import pytest

from facesynth.app.graph import (
    DEFAULT_GRAPH,
    Graph,
    GraphError,
    graph_to_toml,
    load_graph,
    parse_graph,
    select_node,
)
from facesynth.app.nodes import ControlNode, SensorNode, TranslatorNode, stage_of
from facesynth.app.profile_choice import settle_profiles
from facesynth.runtime import keys

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("path", [DEFAULT_GRAPH, ROOT / "deploy" / "graph.toml"], ids=str)
def test_shipped_graphs_load_and_run_every_stage_once(path: Path) -> None:
    graph = load_graph(path)
    assert sorted(stage_of(node) for node in graph.nodes.values()) == sorted(keys.SERVICES)


def test_the_demo_graph_is_the_default() -> None:
    graph = load_graph()
    # No profile named: the record driver has no preference, so it is the default, paper16
    # (facesynth.app.profile_choice; `--driver vmc` makes it arkit52).
    assert graph.nodes["control"] == ControlNode(
        driver={"driver": "record", "out": "facesynth-commands.jsonl"}
    )
    settled = settle_profiles(graph)
    assert settled.nodes["control"].profile == settled.nodes["translator"].profile == "paper16"
    assert graph.nodes["sensor"] == SensorNode(source={"source": "video"})


def test_a_graph_may_run_a_stage_twice() -> None:
    graph = parse_graph(
        {
            "nodes": {
                "head": {"stage": "translator", "profile": "paper16"},
                "face": {"stage": "translator", "profile": "virtual"},
            }
        }
    )
    assert list(graph.of_stage("translator")) == ["head", "face"]
    assert select_node(graph, "translator", "face", "g") == TranslatorNode(profile="virtual")
    with pytest.raises(GraphError, match=r"name the translator node with --node .*head, face"):
        select_node(graph, "translator", None, "g")
    with pytest.raises(GraphError, match="no node 'tail' \\(nodes: head, face\\)"):
        select_node(graph, "translator", "tail", "g")
    with pytest.raises(GraphError, match="node 'head' runs translator, not control"):
        select_node(graph, "control", "head", "g")
    with pytest.raises(GraphError, match="nodes of sensor: none"):
        select_node(graph, "sensor", None, "g")


CASES = [
    ("not toml", "nodes = [", "not valid TOML"),
    ("no nodes", 'rig = "a"\n', "missing required field `nodes`"),
    ("empty", "[nodes]\n", "a graph needs at least one node"),
    ("unknown key", 'wheels = 4\n[nodes.s]\nstage = "sensor"\n', "unknown field `wheels`"),
    (
        "unknown stage",
        '[nodes.x]\nstage = "teleporter"\n',
        "node x: unknown stage 'teleporter' (stages: sensor, points,",
    ),
    ("no stage", "[nodes.x]\nqueue = 2\n", "node x: Object missing required field `stage`"),
    (
        "unknown option",
        '[nodes.x]\nstage = "points"\nspeed = 2\n',
        "node x: Object contains unknown field `speed`",
    ),
    ("bad value", '[nodes.c]\nstage = "control"\nwatchdog = -1\n', "node c: watchdog: Expected"),
    ("wrong type", '[nodes.c]\nstage = "control"\nqueue = "x"\n', "node c: queue: Expected `int`"),
    (
        "unknown driver",
        '[nodes.c]\nstage = "control"\ndriver = { driver = "teleporter" }\n',
        "node c: unknown driver 'teleporter' (known: ",
    ),
    (
        "bad driver option",
        '[nodes.c]\nstage = "control"\ndriver = { driver = "record", out = 3 }\n',
        "node c: driver record: Expected `str`, got `int` - at `$.out`",
    ),
    (
        "bad source",
        '[nodes.s]\nstage = "sensor"\nsource = { source = "ticks" }\n',
        "node s: source ticks: Object missing required field `count`",
    ),
    ("bad rig", 'rig = "a/b"\n[nodes.s]\nstage = "sensor"\n', "invalid rig name 'a/b'"),
    ("bad node name", '[nodes."a b"]\nstage = "sensor"\n', "invalid node name 'a b'"),
]


@pytest.mark.parametrize(("text", "message"), [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_graphs_name_the_file_and_the_problem(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "g.toml"
    path.write_text(text)
    with pytest.raises(GraphError) as info:
        load_graph(path)
    assert str(info.value).startswith(str(path))
    assert message in str(info.value)
    assert "\n" not in str(info.value)


def test_missing_and_unreadable_graphs(tmp_path: Path) -> None:
    with pytest.raises(GraphError, match=r"graph .*gone.toml does not exist"):
        load_graph(tmp_path / "gone.toml")
    (tmp_path / "bin.toml").write_bytes(b"\xff\xfe")
    with pytest.raises(GraphError, match="cannot read graph"):
        load_graph(tmp_path / "bin.toml")


def test_graph_to_toml_round_trips(tmp_path: Path) -> None:
    graph = Graph(
        rig="lab",
        description='a "quoted" graph',
        nodes={
            "sensor": SensorNode(
                source={"source": "video", "path": "/v.mp4", "loop": True, "fps": 25.0},
                max_frames=10,
                wait_for=["points", "control"],
            ),
            "control": ControlNode(driver={"driver": "record", "out": "x.jsonl"}, watchdog=0.25),
        },
    )
    path = tmp_path / "g.toml"
    path.write_text(graph_to_toml(graph))
    assert load_graph(path) == graph


def test_bundled_graphs_by_name_from_any_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 20: `facesynth run face` works outside the checkout; a local file comes first."""
    from facesynth.app.graph import GRAPHS_DIR, bundled_graphs, graph_file, graph_help

    monkeypatch.chdir(tmp_path)
    assert set(bundled_graphs()) == {"demo", "face"}
    assert graph_file("face") == graph_file("face.toml") == GRAPHS_DIR / "face.toml"
    assert load_graph("face").nodes["page"].driver == {
        "driver": "virtual",
        "http": "127.0.0.1:8080",
    }
    assert load_graph("demo").description == load_graph().description
    (tmp_path / "face").write_text('[nodes.f]\nstage = "features"\n')
    assert list(load_graph("face").nodes) == ["f"]
    assert graph_file("sub/face") == Path("sub/face")  # a path is never a bundled name
    for name, description in bundled_graphs().items():
        assert description and f"{name}: {description}" in graph_help()
