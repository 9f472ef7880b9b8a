"""What the two nodes of one robot (T and C) share: its profile, mirroring, name and queue."""

from __future__ import annotations

from typing import Annotated

from msgspec import Meta

from facesynth.app.stages.node import StageNode


class RobotNode(StageNode):
    """What the two nodes of one robot (T and C) share: its profile and its keys."""

    profile: (
        Annotated[
            str,
            Meta(
                description="robot profile name or TOML path (default: the one the control "
                "node's driver expects, vmc: arkit52, virtual: virtual; else paper16)"
            ),
        ]
        | None
    ) = None
    mirror: Annotated[
        bool, Meta(description="mirror the performer (robot's right follows the performer's left)")
    ] = False
    robot: (
        Annotated[
            str,
            Meta(
                description="robot name, when one performer drives several robots: commands on "
                "…/servo_commands/ROBOT and state on …/servo_state/ROBOT (default: the rig's "
                "single-robot keys)"
            ),
        ]
        | None
    ) = None
    queue: Annotated[int, Meta(ge=1, description="input queue length; 1 = latest only")] = 8
