"""C, the control interface: checked, clamped commands to a servo driver; what was applied on
``…/servo_state``."""

from __future__ import annotations

from typing import Annotated, Any, Literal

import msgspec
from msgspec import Meta

from facesynth.app.arguments import OptionError
from facesynth.app.stages.descriptor import NodeBuild, PluginTable, StageDescriptor, StageParts
from facesynth.app.stages.driver_fit import check_fit
from facesynth.app.stages.robot import RobotNode
from facesynth.runtime.profiles import Profile
from facesynth.services.control.drivers.registry import DRIVERS
from facesynth.services.control.service import ControlService


class ControlNode(RobotNode, tag="control"):
    """C: checked, clamped commands to a servo driver; what was applied on ``…/servo_state``."""

    driver: dict[str, Any] = msgspec.field(default_factory=lambda: {"driver": "record"})
    watchdog: Annotated[
        float,
        Meta(gt=0, description="seconds without commands before the face returns to neutral"),
    ] = 0.5
    motion_time: Annotated[
        Literal["real", "media"] | None,
        Meta(
            description="what the servos' speed limits are measured on: real time, or the "
            "commands' media time (a --fast replay to a file or a virtual face, deterministic; "
            "refused for drivers that move hardware). Default: media when the graph's sensor "
            "is --fast and the driver moves no hardware, else real"
        ),
    ] = None


def control_service(
    node: ControlNode, driver: msgspec.Struct, profile: Profile, fast: bool = False
) -> ControlService:
    """The control interface of a node, with its driver and (settled) profile.

    Speed limits are measured on media time only for a ``--fast`` chain (``fast``) or when
    asked, and never for a driver that moves hardware.
    """
    check_fit(driver, profile)
    output = DRIVERS.build(driver, profile)
    motion_time = node.motion_time
    if motion_time == "media" and output.moves_hardware:
        raise OptionError(
            f"--motion-time media measures speed limits on the commands' media time, which "
            f"is not for the {driver.__struct_config__.tag} driver: it moves a real head"
        )
    if motion_time is None:
        motion_time = "media" if fast and not output.moves_hardware else "real"
    return ControlService(
        profile, output, watchdog_s=node.watchdog, queue=node.queue, motion_time=motion_time
    )


def build(request: NodeBuild) -> StageParts:
    """A control node: its driver and its settled profile."""
    node: ControlNode = request.node
    assert request.config is not None
    profile = request.setup.profile(node.profile, node.mirror)
    control = control_service(node, request.config, profile, request.fast)
    return StageParts(request.name, STAGE.name, control.serve, control, robot=node.robot)


STAGE = StageDescriptor(
    name="control",
    node=ControlNode,
    build=build,
    consumes="servo_commands",
    produces="servo_state",
    help="C: drive servos (or record) from …/servo_commands; `control test` and "
    "`control status` are bring-up tools for a servo board",
    plugin=PluginTable(
        "driver", DRIVERS, "--driver", default="record", config_flag="--driver-config"
    ),
)
