"""What every node of a graph may hold, whatever its stage: the base of each stage's node struct.

A stage's node struct (its options in a graph file's ``[nodes.NAME]`` table) subclasses
:class:`StageNode` with ``tag="<stage name>"``: the ``stage`` key of the table names it.
"""

from __future__ import annotations

from typing import Annotated

import msgspec
from msgspec import Meta

from facesynth.runtime.capture_age import DEFAULT_MAX_AGE_S

#: P's and F's input-age limit (``max_input_age_s``): one flag for both stages.
InputAge = Annotated[
    float,
    Meta(
        ge=0,
        le=3600,
        description="drop an input whose frame was captured longer ago than this many seconds "
        f"when its turn comes, e.g. after a stall upstream (default {DEFAULT_MAX_AGE_S:g}; "
        "0 = never drop)",
    ),
]


class StageNode(msgspec.Struct, kw_only=True, forbid_unknown_fields=True, tag_field="stage"):
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


def stage_of(node: msgspec.Struct) -> str:
    """The stage a node runs (its struct's tag)."""
    return str(node.__struct_config__.tag)
