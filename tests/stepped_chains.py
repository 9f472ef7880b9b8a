"""A graph's points, features and translator nodes as a :class:`SteppedChain`, built as
``facesynth run`` builds them: shared by the tests that hold the stepped chain to ``run``
(tests/app/engine/test_stepped.py) and those that, once that holds, step a run's recorded
points through other profiles instead of running the tracker again
(tests/integration/test_face_sections.py)."""

from __future__ import annotations

from facesynth.app.engine.stepped import RobotCores, SteppedChain, control_core
from facesynth.app.graph import Graph
from facesynth.app.nodes import stage_of
from facesynth.app.profile_choice import settle
from facesynth.app.stages.setup import Setup
from facesynth.app.wiring import build_node


def graph_chain(graph: Graph, setup: Setup | None = None) -> SteppedChain:
    """The graph's points, features and translator nodes (one of each at most) built as
    ``run`` builds them (:func:`facesynth.app.wiring.build_node`, from the graph's settled
    ``setup``, default: settled now), the translator with the graph's control node."""
    setup = settle(graph, {}) if setup is None else setup
    built = {
        stage_of(node): (name, build_node(name, node, graph, None, setup=setup).service)
        for name, node in graph.nodes.items()
        if stage_of(node) in ("points", "features", "translator")
    }
    robots = []
    if "translator" in built:
        ((name, control),) = graph.of_stage("control").items()
        core = control_core(control, setup.configs.get(name), setup.fast, setup)
        robots.append(RobotCores(*built["translator"], core))
    services = {stage: service for stage, (_, service) in built.items()}
    return SteppedChain(services.get("points"), services.get("features"), robots)
