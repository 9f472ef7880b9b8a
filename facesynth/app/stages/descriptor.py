"""A stage, described once: its node struct, how a node becomes a running service, the keys it
reads and writes, and the plugin table it takes.

Each stage module of :mod:`facesynth.app.stages` exports ``STAGE``, a :class:`StageDescriptor`;
the registry (:mod:`facesynth.app.stages.registry`) finds them, and the graph, the command line
and the runner read everything stage-specific from there.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import msgspec

from facesynth.app.stages.node import StageNode
from facesynth.runtime.keys import Stage
from facesynth.runtime.plugins import Registry
from facesynth.runtime.service import ServiceContext

if TYPE_CHECKING:
    from facesynth.app.stages.setup import Setup

ServiceBody = Callable[[ServiceContext], Awaitable[Any]]


@dataclass
class StageParts:
    """What one node became: its service body, and the objects a runner may look at."""

    name: str
    stage: str
    body: ServiceBody
    service: Any = None
    #: The robot whose command keys the node uses (a rig driving several robots), if any.
    robot: str | None = None


@dataclass(frozen=True)
class PluginTable:
    """A stage's plugin table (``source = { source = "video" }``) and how the CLI chooses it."""

    #: The node field holding the table, also the plugin's tag field (``driver``).
    field: str
    registry: Registry[Any]
    #: The flag choosing the plugin (``--driver NAME``).
    flag: str
    #: The plugin a bare stage command uses.
    default: str
    #: The flag giving the plugin's whole config as JSON, if any (``--driver-config``).
    config_flag: str | None = None


@dataclass(frozen=True)
class NodeBuild:
    """Everything a stage's build function is given for one node."""

    name: str
    node: Any
    #: The node's validated plugin config (None for a stage without one).
    config: msgspec.Struct | None
    #: The choices settled once for the whole chain: profiles, F's neutral window, drivers.
    setup: Setup
    #: Frames of a replayed point stream in the chain, if any (ticks then drive the sensor).
    replay_frames: int | None = None
    #: Whether the chain's input comes faster than real time.
    fast: bool = False
    #: Whether the node runs as a service of its own (``facesynth STAGE``).
    standalone: bool = False


@dataclass(frozen=True)
class StageDescriptor:
    """One stage of the chain."""

    #: The stage's name: its node tag, its command, its service name on the bus.
    name: str
    #: The node struct (a :class:`StageNode` tagged with ``name``).
    node: type[StageNode]
    #: Builds a node of the stage into its running form.
    build: Callable[[NodeBuild], StageParts]
    #: The data key the stage reads (None: the chain's source) and the one it writes (None:
    #: a sink, which only watches).
    consumes: Stage | None
    produces: Stage | None
    #: One line: the stage command's help.
    help: str
    #: Its plugin table, if it takes one.
    plugin: PluginTable | None = None

    def __post_init__(self) -> None:
        tag = self.node.__struct_config__.tag
        if tag != self.name:
            raise TypeError(f"stage {self.name}: its node struct is tagged {tag!r}")
