"""Setup is settled once, in one place (issue #28): ``facesynth run`` reads each profile file
once at start and hands the settled choice (profile, F's neutral window, driver) to the nodes,
instead of C's driver choosing T's profile, T's profile F's window, and each re-reading it."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path
from typing import Any

import cv2
import pytest

from facesynth.app.cli import main
from facesynth.app.data import sample_openface_csv, sample_video
from facesynth.app.graph import parse_graph
from facesynth.app.profile_choice import settle
from facesynth.app.wiring import build_node
from facesynth.runtime.profiles import loading


@pytest.fixture
def profile_reads(monkeypatch: pytest.MonkeyPatch) -> Counter[str]:
    """Every profile file parsed from now on, counted by its path."""
    reads: Counter[str] = Counter()
    parse = loading.parse_profile

    def counting(text: str, source: str, *args: Any, **kwargs: Any) -> Any:
        reads[Path(source).name] += 1
        return parse(text, source, *args, **kwargs)

    monkeypatch.setattr(loading, "parse_profile", counting)
    return reads


def _short_video(folder: Path, frames: int = 3) -> Path:
    """The sample video's first ``frames`` frames as their own file."""
    path = folder / "short.avi"
    capture = cv2.VideoCapture(str(sample_video()))
    writer = None
    for _ in range(frames):
        ok, image = capture.read()
        assert ok
        if writer is None:
            size = (image.shape[1], image.shape[0])
            writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"MJPG"), 30.0, size)
        writer.write(image)
    assert writer is not None
    writer.release()
    capture.release()
    return path


@pytest.mark.parametrize(
    ("run", "reads"),
    [
        # T, C, C's driver check and F's neutral window all take paper16 from one read.
        ("openface", {"paper16.toml": 1}),
        # The render after the run too (F's window, the bars' T and C): the settled paper16;
        # its face's profile (the tracker gives blendshapes) is read once for its T and C.
        ("render", {"paper16.toml": 1, "virtual_bs.toml": 1}),
    ],
    ids=["openface csv", "--render"],
)
def test_run_reads_the_profile_file_once(
    run: str,
    reads: dict[str, int],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    profile_reads: Counter[str],
) -> None:
    argv = ["run", "--fast", "--out", str(tmp_path / "commands.jsonl")]
    if run == "openface":
        argv += ["--openface-csv", str(sample_openface_csv()), "--max-frames", "5"]
    else:
        argv += ["--video", str(_short_video(tmp_path)), "--render", str(tmp_path / "r.mp4")]
    assert main([*argv, "--listen", "tcp/127.0.0.1:0"]) == 0
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert summary["commands"] > 0
    if run == "render":
        assert summary["render"]["frames"] == 3
    assert profile_reads == reads


def _slow_profile(tmp_path: Path) -> Path:
    """paper16 with a neutral window of 2.5 s."""
    text = (loading.resolve_profile("paper16")).read_text(encoding="utf-8")
    assert "neutral_seconds = 1.0" in text
    path = tmp_path / "slow.toml"
    path.write_text(text.replace("neutral_seconds = 1.0", "neutral_seconds = 2.5"))
    return path


def test_features_takes_its_neutral_window_from_the_settled_setup(
    tmp_path: Path, profile_reads: Counter[str]
) -> None:
    slow = str(_slow_profile(tmp_path))
    out = str(tmp_path / "x.jsonl")
    graph = parse_graph(
        {
            "nodes": {
                "f": {"stage": "features"},
                "t": {"stage": "translator"},
                "c": {
                    "stage": "control",
                    "profile": slow,
                    "driver": {"driver": "record", "out": out},
                },
            }
        }
    )
    setup = settle(graph)
    assert graph.nodes["t"].profile == slow  # the control node's, settled once for T too
    assert setup.neutral_seconds() == 2.5
    parts = {name: build_node(name, node, graph, setup=setup) for name, node in graph.nodes.items()}
    assert parts["f"].service.estimator._window.window_ns == 2_500_000_000
    assert parts["t"].service.profile.name == parts["c"].service.core.profile.name
    assert profile_reads == {"slow.toml": 1}


def test_each_node_gets_its_own_copy_mirrored_as_it_asks(
    tmp_path: Path, profile_reads: Counter[str]
) -> None:
    out = str(tmp_path / "x.jsonl")
    graph = parse_graph(
        {
            "nodes": {
                "t": {"stage": "translator", "profile": "paper16", "mirror": True},
                "c": {"stage": "control", "driver": {"driver": "record", "out": out}},
            }
        }
    )
    setup = settle(graph)
    translator = build_node("t", graph.nodes["t"], graph, setup=setup).service
    control = build_node("c", graph.nodes["c"], graph, setup=setup).service
    loaded = setup.loaded("paper16")
    assert translator.profile.mirror is not loaded.mirror
    assert control.core.profile.mirror is loaded.mirror
    assert translator.profile is not loaded and control.core.profile is not loaded
    assert profile_reads == {"paper16.toml": 1}


def test_a_node_built_alone_names_its_profile_as_before(profile_reads: Counter[str]) -> None:
    """build_node without a settled setup (a tool building one node) reads what it needs."""
    graph = parse_graph({"nodes": {"t": {"stage": "translator", "profile": "head16"}}})
    translator = build_node("t", graph.nodes["t"], graph).service
    assert translator.profile.name == "head16"
    assert profile_reads == {"head16.toml": 1}
