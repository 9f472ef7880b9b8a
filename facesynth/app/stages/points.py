"""P, the points: landmarks of each frame (tracker, or a replayed recording) on ``…/points``."""

from __future__ import annotations

from typing import Annotated, Any

import msgspec
from msgspec import Meta

from facesynth.app.stages.descriptor import NodeBuild, PluginTable, StageDescriptor, StageParts
from facesynth.app.stages.node import InputAge, StageNode
from facesynth.runtime.capture_age import DEFAULT_MAX_AGE_S
from facesynth.services.points.backends.base import PointsBackend
from facesynth.services.points.backends.registry import BACKENDS
from facesynth.services.points.service import serve_points


class PointsNode(StageNode, tag="points"):
    """P: landmarks of each frame on ``…/points``."""

    backend: dict[str, Any] = msgspec.field(default_factory=lambda: {"backend": "tracker"})
    queue: Annotated[int, Meta(ge=1, description="input queue length; 1 = latest only")] = 2
    max_input_age_s: InputAge = DEFAULT_MAX_AGE_S


def build_backend(config: msgspec.Struct) -> PointsBackend:
    """The points backend of a config (the tracker loads its models here)."""
    return BACKENDS.build(config)


def build(request: NodeBuild) -> StageParts:
    """A points node: its backend, serving the frames on the bus."""
    assert request.config is not None
    backend = build_backend(request.config)
    node: PointsNode = request.node
    return StageParts(
        request.name,
        STAGE.name,
        lambda ctx: serve_points(ctx, backend, node.queue, node.max_input_age_s),
        backend,
    )


STAGE = StageDescriptor(
    name="points",
    node=PointsNode,
    build=build,
    consumes="input",
    produces="points",
    help="P: publish face landmarks on …/points (tracker, or a replayed recording)",
    plugin=PluginTable("backend", BACKENDS, "--backend", default="tracker"),
)
