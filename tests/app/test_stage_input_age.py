"""P's and F's input-age limit is a node option: ``max_input_age_s`` (``--max-input-age-s``).

Each node is made as ``facesynth points|features`` makes it (its command line through the
stage's flags, built by its descriptor) and its service runs on the in-memory bus in virtual
time; the frames name this host as their capture host, so their age is exact from the first.
"""

from __future__ import annotations

from pathlib import Path

import msgspec
import pytest

from facesynth.app.cli import build_parser
from facesynth.app.data import sample_openface_csv
from facesynth.app.graph import Graph, load_graph
from facesynth.app.stage_args import apply_arguments
from facesynth.app.stages.descriptor import ServiceBody
from facesynth.app.stages.features import FeaturesNode
from facesynth.app.stages.points import PointsNode
from facesynth.app.stages.registry import STAGES
from facesynth.app.wiring import build_node
from facesynth.runtime.capture_age import DEFAULT_MAX_AGE_S
from facesynth.runtime.clock_host import clock_host
from facesynth.runtime.testing import StageRun
from facesynth.schemas.messages import Frame, Points

MS = 1_000_000
HOST = clock_host()


def frame(seq: int, t_capture_ns: int) -> Frame:
    return Frame(
        seq=seq,
        t_capture_ns=t_capture_ns,
        t_media_ns=seq * 33 * MS,
        width=640,
        height=480,
        encoding="none",
        capture_host=HOST,
    )


def points(seq: int, t_capture_ns: int) -> Points:
    return Points(
        seq=seq,
        t_capture_ns=t_capture_ns,
        t_media_ns=seq * 33 * MS,
        face=False,
        image_width=640,
        image_height=480,
        capture_host=HOST,
    )


#: stage: (its own command-line options, a message of its input)
CHAIN = {
    "points": (["--openface-csv", str(sample_openface_csv()), "--loop-replay"], frame),
    "features": ([], points),
}


def service_body(stage: str, age_flags: list[str]) -> ServiceBody:
    """The service of the node ``facesynth STAGE [flags]`` makes."""
    own, _ = CHAIN[stage]
    args = build_parser().parse_args([stage, *own, *age_flags])
    node, config = apply_arguments(stage, STAGES.get(stage).node(), args)
    parts = build_node(stage, node, Graph(nodes={stage: node}), config)
    return parts.body


async def ages_through(stage: str, age_flags: list[str], ages_s: list[float]) -> list[int]:
    """The sequence numbers ``stage`` publishes of inputs captured ``ages_s`` ago, and checks
    that every one it left out was counted stale (not rejected)."""
    body = service_body(stage, age_flags)
    descriptor = STAGES.get(stage)
    consumes, produces = descriptor.consumes, descriptor.produces
    assert consumes is not None and produces is not None
    _, message = CHAIN[stage]
    async with StageRun(body, service=stage) as run:
        for seq, age_s in enumerate(ages_s):
            await run.send(consumes, message(seq, run.clock.time_ns() - round(age_s * 1e9)))
        out = [m.seq for m in run.messages(produces)]
        assert run.ctx.stats.stale == len(ages_s) - len(out)
        assert run.ctx.stats.rejected == 0
    return out


@pytest.mark.parametrize("stage", list(CHAIN))
async def test_an_input_older_than_the_default_limit_is_dropped_and_counted_stale(
    stage: str,
) -> None:
    assert await ages_through(stage, [], [0.01, 0.6, 0.02]) == [0, 2]


@pytest.mark.parametrize("stage", list(CHAIN))
async def test_a_larger_limit_lets_it_through_and_a_smaller_one_drops_more(stage: str) -> None:
    assert await ages_through(stage, ["--max-input-age-s", "1"], [0.01, 0.6, 1.5]) == [0, 1]
    assert await ages_through(stage, ["--max-input-age-s", "0.1"], [0.01, 0.15, 0.05]) == [0, 2]


@pytest.mark.parametrize("stage", list(CHAIN))
async def test_zero_never_drops_an_input_for_its_age(stage: str) -> None:
    assert await ages_through(stage, ["--max-input-age-s", "0"], [0.01, 60.0, 3.0]) == [0, 1, 2]


def test_the_option_defaults_to_the_profiles_command_age_and_is_a_graph_key(
    tmp_path: Path,
) -> None:
    assert PointsNode().max_input_age_s == FeaturesNode().max_input_age_s == DEFAULT_MAX_AGE_S
    graph_file = tmp_path / "age.toml"
    graph_file.write_text(
        '[nodes.p]\nstage = "points"\nmax_input_age_s = 2.5\n'
        '[nodes.f]\nstage = "features"\nmax_input_age_s = 0\n'
    )
    graph = load_graph(str(graph_file), plugins=False)
    assert msgspec.structs.asdict(graph.nodes["p"])["max_input_age_s"] == 2.5
    assert msgspec.structs.asdict(graph.nodes["f"])["max_input_age_s"] == 0.0
