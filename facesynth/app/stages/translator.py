"""T, the translator: servo positions through a robot profile on ``…/servo_commands``."""

from __future__ import annotations

from typing import Annotated

from msgspec import Meta

from facesynth.app.stages.calibration import build_calibration
from facesynth.app.stages.closed_loop import robot_face
from facesynth.app.stages.descriptor import NodeBuild, StageDescriptor, StageParts
from facesynth.app.stages.robot import RobotNode
from facesynth.services.translator.core import Translator
from facesynth.services.translator.service import serve_translator


class TranslatorNode(RobotNode, tag="translator"):
    """T: servo positions through a robot profile on ``…/servo_commands``."""

    calibration: (
        Annotated[str, Meta(description="performer calibration (neutral + ranges): NAME or PATH")]
        | None
    ) = None
    robot_rig: (
        Annotated[
            str,
            Meta(
                description="close the loop through the robot's own camera: the rig whose "
                "…/features is the robot's face (its camera's sensor, points and features "
                "nodes); a learned profile only"
            ),
        ]
        | None
    ) = None
    robot_camera: (
        Annotated[
            str,
            Meta(
                description="close the loop through the robot's own camera, tracked in this "
                "process (tracker and F): a device index, a /dev/video* path or a stream URL; "
                "a learned profile only"
            ),
        ]
        | None
    ) = None
    loop_state: (
        Annotated[
            str,
            Meta(
                description="with --robot-rig or --robot-camera: the file the closed loop "
                "keeps what it learns in (default: beside the learned profile, NAME.loop)"
            ),
        ]
        | None
    ) = None


def build(request: NodeBuild) -> StageParts:
    """A translator node: its settled profile and its calibration."""
    node: TranslatorNode = request.node
    translator = Translator(
        request.setup.profile(node.profile, node.mirror), build_calibration(node.calibration)
    )
    face = robot_face(translator, node.robot_rig, node.profile, node.loop_state, node.robot_camera)
    return StageParts(
        request.name,
        STAGE.name,
        lambda ctx: serve_translator(ctx, translator, node.queue, face),
        translator,
        robot=node.robot,
    )


STAGE = StageDescriptor(
    name="translator",
    node=TranslatorNode,
    build=build,
    consumes="features",
    produces="servo_commands",
    help="T: publish servo positions on …/servo_commands through a profile",
)
