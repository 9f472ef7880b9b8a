"""The graph file's JSON Schema (``facesynth/app/graphs/graph.schema.json``): generated from the
stages and plugins, checked in, kept fresh, and every shipped graph file valid against it."""

from __future__ import annotations

import json
import re
import tomllib
from pathlib import Path
from typing import Any

import jsonschema
import pytest

from facesynth.app import graph_schema
from facesynth.app.graph import GraphError, parse_graph

ROOT = Path(__file__).resolve().parents[2]


def _validator() -> jsonschema.Draft202012Validator:
    schema = json.loads(graph_schema.SCHEMA_PATH.read_text(encoding="utf-8"))
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


def test_the_checked_in_schema_is_current() -> None:
    assert graph_schema.SCHEMA_PATH.read_text(encoding="utf-8") == graph_schema.render_schema(), (
        "facesynth/app/graphs/graph.schema.json is stale: run python -m facesynth.app.graph_schema"
    )


def test_check_mode_fails_on_a_stale_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    stale = tmp_path / "graph.schema.json"
    stale.write_text("{}\n")
    monkeypatch.setattr(graph_schema, "SCHEMA_PATH", stale)
    assert graph_schema.main(["--check"]) == 1
    assert "is stale: run python -m facesynth.app.graph_schema" in capsys.readouterr().err
    assert graph_schema.main([]) == 0
    assert stale.read_text(encoding="utf-8") == graph_schema.render_schema()
    assert graph_schema.main(["--check"]) == 0


def _shipped_graph_files() -> list[Path]:
    """Every TOML file shipped or deployed that is a graph (it has a ``nodes`` table)."""
    found = []
    for folder in (ROOT / "facesynth" / "app" / "graphs", ROOT / "deploy"):
        for path in sorted(folder.rglob("*.toml")):
            if "nodes" in tomllib.loads(path.read_text(encoding="utf-8")):
                found.append(path)
    return found


def test_the_shipped_graph_files_are_found() -> None:
    names = {path.relative_to(ROOT).as_posix() for path in _shipped_graph_files()}
    assert {
        "facesynth/app/graphs/demo.toml",
        "facesynth/app/graphs/face.toml",
        "deploy/graph.toml",
        "deploy/board/control.toml",
    } <= names


@pytest.mark.parametrize(
    "path", _shipped_graph_files(), ids=lambda p: p.relative_to(ROOT).as_posix()
)
def test_every_shipped_graph_file_is_valid(path: Path) -> None:
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    errors = [error.message for error in _validator().iter_errors(data)]
    assert errors == []
    parse_graph(data, str(path), plugins=False)  # and the loader agrees


def _documented_graphs() -> list[tuple[str, str]]:
    """The graph examples (TOML blocks with nodes) of the architecture page and the docs."""
    blocks = []
    for path in [ROOT / "ARCHITECTURE.md", *sorted((ROOT / "docs").rglob("*.md"))]:
        text = path.read_text(encoding="utf-8")
        for number, match in enumerate(re.finditer(r"```toml\n(.*?)```", text, re.S)):
            if "[nodes." in match.group(1):
                blocks.append((f"{path.relative_to(ROOT).as_posix()}#{number}", match.group(1)))
    return blocks


def test_the_documented_graphs_are_valid() -> None:
    blocks = _documented_graphs()
    assert len(blocks) >= 2
    for where, text in blocks:
        errors = [error.message for error in _validator().iter_errors(tomllib.loads(text))]
        assert errors == [], where


MALFORMED: list[tuple[str, dict[str, Any]]] = [
    ("no nodes", {"rig": "a"}),
    ("no node at all", {"nodes": {}}),
    ("unknown key", {"wheels": 4, "nodes": {"s": {"stage": "sensor"}}}),
    ("unknown stage", {"nodes": {"x": {"stage": "teleporter"}}}),
    ("no stage", {"nodes": {"x": {"queue": 2}}}),
    ("unknown option", {"nodes": {"x": {"stage": "points", "speed": 2}}}),
    ("bad value", {"nodes": {"c": {"stage": "control", "watchdog": -1}}}),
    ("wrong type", {"nodes": {"c": {"stage": "control", "queue": "x"}}}),
    ("unknown driver", {"nodes": {"c": {"stage": "control", "driver": {"driver": "teleporter"}}}}),
    (
        "bad driver option",
        {"nodes": {"c": {"stage": "control", "driver": {"driver": "record", "out": 3}}}},
    ),
    ("bad source", {"nodes": {"s": {"stage": "sensor", "source": {"source": "ticks"}}}}),
    ("bad rig", {"rig": "a/b", "nodes": {"s": {"stage": "sensor"}}}),
    ("bad node name", {"nodes": {"a b": {"stage": "sensor"}}}),
]


@pytest.mark.parametrize(("data"), [c[1] for c in MALFORMED], ids=[c[0] for c in MALFORMED])
def test_the_schema_refuses_what_the_loader_refuses(data: dict[str, Any]) -> None:
    assert list(_validator().iter_errors(data)), "the schema let a malformed graph through"
    with pytest.raises(GraphError):
        parse_graph(data)
