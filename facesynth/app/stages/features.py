"""F, the features: pose-free features of each face on ``…/features``."""

from __future__ import annotations

from typing import Annotated

from msgspec import Meta

from facesynth.app.arguments import OptionError
from facesynth.app.stages.calibration import build_calibration
from facesynth.app.stages.descriptor import NodeBuild, StageDescriptor, StageParts
from facesynth.app.stages.node import InputAge, StageNode
from facesynth.app.stages.setup import DEFAULT_NEUTRAL_S
from facesynth.runtime.capture_age import DEFAULT_MAX_AGE_S
from facesynth.services.features.core import FeatureProcessor
from facesynth.services.features.service import StateKeeping, serve_features
from facesynth.services.features.state import StateError
from facesynth.services.features.state import check_name as check_state_name


class FeaturesNode(StageNode, tag="features"):
    """F: pose-free features on ``…/features``."""

    calibration: (
        Annotated[str, Meta(description="performer calibration (neutral + ranges): NAME or PATH")]
        | None
    ) = None
    auto_range: Annotated[
        bool,
        Meta(
            description="without a calibration: adapt the neutral (rolling median) and the "
            "feature ranges (slowly decaying extremes) to the running stream"
        ),
    ] = False
    neutral_seconds: (
        Annotated[
            float,
            Meta(
                gt=0,
                description="without a calibration: seconds of face used as neutral "
                "(default: the translator profile's, else 1 s)",
            ),
        ]
        | None
    ) = None
    neutral_held: Annotated[
        bool,
        Meta(
            description="the face is held at its neutral over the first seconds (a robot's "
            "camera, as facesynth learn does): take that neutral as it is, brows included"
        ),
    ] = False
    queue: Annotated[int, Meta(ge=1, description="input queue length; 1 = latest only")] = 8
    max_input_age_s: InputAge = DEFAULT_MAX_AGE_S
    performer: Annotated[
        str,
        Meta(
            description="without a calibration: whose learned neutral and ranges are kept "
            "(one file per rig and performer)"
        ),
    ] = "default"
    keep_state: Annotated[
        bool | None,
        Meta(
            description="without a calibration: keep the learned neutral and ranges on disk so "
            "a restarted F picks up where it was (default: on for a service of its own, off in "
            "`run` and `replay`, whose input starts afresh)"
        ),
    ] = None
    state_dir: Annotated[
        str | None,
        Meta(
            description="where learned state is kept (default $FACESYNTH_STATE, else "
            "~/.config/facesynth/state)"
        ),
    ] = None
    relearn: Annotated[
        bool, Meta(description="ignore the kept neutral and ranges: learn afresh, then keep them")
    ] = False


def build_processor(
    node: FeaturesNode, default_neutral_s: float = DEFAULT_NEUTRAL_S
) -> FeatureProcessor:
    """The feature processor, with the calibration's neutral when there is one."""
    seconds = node.neutral_seconds if node.neutral_seconds is not None else default_neutral_s
    calibration = build_calibration(node.calibration)
    if calibration is not None:
        return FeatureProcessor.from_calibration(
            calibration, neutral_seconds=seconds, auto_range=node.auto_range
        )
    return FeatureProcessor(
        neutral_seconds=seconds, auto_range=node.auto_range, neutral_held=node.neutral_held
    )


def state_keeping(node: FeaturesNode, standalone: bool) -> StateKeeping | None:
    """Whether and where F keeps its learned neutral: not with a calibration; by default only
    for a service of its own (a one-process ``run`` or ``replay`` starts its input afresh)."""
    keep = node.keep_state if node.keep_state is not None else standalone
    if not keep or node.calibration:
        return None
    try:
        check_state_name(node.performer, "performer")
    except StateError as exc:
        raise OptionError(str(exc)) from None
    return StateKeeping(node.performer, node.state_dir, node.relearn)


def build(request: NodeBuild) -> StageParts:
    """A features node: its processor, with the neutral window the setup settled."""
    node: FeaturesNode = request.node
    processor = build_processor(node, request.setup.neutral_seconds())
    keeping = state_keeping(node, request.standalone)
    return StageParts(
        request.name,
        STAGE.name,
        lambda ctx: serve_features(ctx, processor, node.queue, keeping, node.max_input_age_s),
        processor,
    )


STAGE = StageDescriptor(
    name="features",
    node=FeaturesNode,
    build=build,
    consumes="points",
    produces="features",
    help="F: publish pose-free features on …/features",
)
