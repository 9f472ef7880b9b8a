"""The nodes of a chain graph: one options struct per stage, tagged with the stage's name.

A node's fields are its stage's options, read from a graph file (``[nodes.NAME]`` with
``stage = "…"``) and overridden by command-line flags, which are derived from these fields
(:mod:`facesynth.app.arguments`). Plugin configs (the sensor's ``source``, the point streamer's
``backend``, the control interface's ``driver``) are plain tables here, validated by their
registries, so a plugin registered at run time is as usable as a shipped one.

Each struct lives with its stage's descriptor (:mod:`facesynth.app.stages`); the registry
``STAGES`` is the list of stages. This module names the shipped ones for the application.
"""

from __future__ import annotations

from typing import Union

from facesynth.app.stages.control import ControlNode
from facesynth.app.stages.features import FeaturesNode
from facesynth.app.stages.node import StageNode, stage_of
from facesynth.app.stages.points import PointsNode
from facesynth.app.stages.registry import STAGES
from facesynth.app.stages.robot import RobotNode
from facesynth.app.stages.sensor import SensorNode
from facesynth.app.stages.setup import DEFAULT_PROFILE
from facesynth.app.stages.translator import TranslatorNode

__all__ = [
    "DEFAULT_PROFILE",
    "PLUGIN_FIELDS",
    "STAGES",
    "ControlNode",
    "FeaturesNode",
    "Node",
    "PointsNode",
    "RobotNode",
    "SensorNode",
    "StageNode",
    "TranslatorNode",
    "stage_of",
]

#: The CLI takes these fields through plugin flags (``--driver``, ``--video``, ``--openface-csv``).
PLUGIN_FIELDS = STAGES.plugin_fields()

#: The shipped stages' nodes, for type checking (a graph holds any registered stage's node).
Node = Union[SensorNode, PointsNode, FeaturesNode, TranslatorNode, ControlNode]  # noqa: UP007
