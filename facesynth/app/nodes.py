"""The nodes of a chain graph: one options struct per stage, tagged with the stage's name.

A node's fields are its stage's options, read from a graph file (``[nodes.NAME]`` with
``stage = "…"``) and overridden by command-line flags, which are derived from these fields
(:mod:`facesynth.app.arguments`). Plugin configs (the sensor's ``source``, the point streamer's
``backend``, the control interface's ``driver``) are plain tables here, validated by their
registries, so a plugin registered at run time is as usable as a shipped one.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal, Union

import msgspec
from msgspec import Meta

from facesynth.runtime import keys

#: The profile of a robot whose nodes and driver name none (:mod:`facesynth.app.profile_choice`).
DEFAULT_PROFILE = "paper16"

#: The CLI takes these fields through plugin flags (``--driver``, ``--video``, ``--openface-csv``).
PLUGIN_FIELDS = ("source", "backend", "driver")


class _Node(msgspec.Struct, kw_only=True, forbid_unknown_fields=True, tag_field="stage"):
    """Options every node may have: a description, and how its process is scheduled
    (:mod:`facesynth.app.tuning`; ``facesynth run`` gives its one process the most demanding
    request of its nodes)."""

    description: Annotated[str, Meta(extra={"cli": False})] = ""
    realtime: (
        Annotated[
            int,
            Meta(
                ge=1,
                le=99,
                description="run the node's process at this real-time priority (SCHED_FIFO "
                "1-99; ahead of every normal program: keeps latency on a busy machine; needs "
                "CAP_SYS_NICE or ulimit -r)",
            ),
        ]
        | None
    ) = None
    nice: (
        Annotated[
            int,
            Meta(
                ge=-20,
                le=19,
                description="niceness of the node's process (-20..19; negative needs "
                "CAP_SYS_NICE or ulimit -e)",
            ),
        ]
        | None
    ) = None
    cpus: Annotated[
        list[int], Meta(description="cores the node's process may run on, e.g. 1 or 0,1")
    ] = []


class SensorNode(_Node, tag="sensor"):
    """S: frames from a source on ``…/input``."""

    source: dict[str, Any] = msgspec.field(default_factory=lambda: {"source": "video"})
    fast: Annotated[
        bool, Meta(description="as fast as the chain takes frames, none lost (default: real time)")
    ] = False
    window: Annotated[
        int, Meta(ge=1, description="--fast: frames in flight ahead of the last servo command")
    ] = 2
    encoding: Annotated[
        Literal["jpeg", "raw"], Meta(description="frame encoding on the bus (default jpeg)")
    ] = "jpeg"
    quality: Annotated[int, Meta(ge=1, le=100, description="JPEG quality 1-100 (default 90)")] = 90
    max_frames: Annotated[int, Meta(ge=0, description="stop after N frames")] | None = None
    wait_for: Annotated[
        list[str],
        Meta(
            description="wait until these services are alive before sending, e.g. "
            "points,features,translator,control (default: the graph's other stages)"
        ),
    ] = []
    wait_timeout: Annotated[
        float, Meta(ge=0, description="seconds to wait for --wait-for (default 30)")
    ] = 30.0
    capture_age: Annotated[
        bool,
        Meta(
            description="name this host as the frames' capture host, so the stages downstream "
            "drop frames too old to act on after a stall (default on; off for a camera that "
            "only measures, as learn's robot camera; --fast frames are never aged)"
        ),
    ] = True


class PointsNode(_Node, tag="points"):
    """P: landmarks of each frame on ``…/points``."""

    backend: dict[str, Any] = msgspec.field(default_factory=lambda: {"backend": "tracker"})
    queue: Annotated[int, Meta(ge=1, description="input queue length; 1 = latest only")] = 2


class FeaturesNode(_Node, tag="features"):
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


class _RobotNode(_Node):
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


class TranslatorNode(_RobotNode, tag="translator"):
    """T: servo positions through a robot profile on ``…/servo_commands``."""

    calibration: (
        Annotated[str, Meta(description="performer calibration (neutral + ranges): NAME or PATH")]
        | None
    ) = None


class ControlNode(_RobotNode, tag="control"):
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


Node = Union[SensorNode, PointsNode, FeaturesNode, TranslatorNode, ControlNode]  # noqa: UP007

#: Node struct of each stage, in chain order.
NODE_TYPES: dict[str, type[Node]] = {
    "sensor": SensorNode,
    "points": PointsNode,
    "features": FeaturesNode,
    "translator": TranslatorNode,
    "control": ControlNode,
}
assert tuple(NODE_TYPES) == keys.SERVICES


def stage_of(node: msgspec.Struct) -> str:
    """The stage a node runs."""
    return str(node.__struct_config__.tag)
