"""The robot's own rig, for a run that poses the robot and looks at its face through its camera.

``facesynth learn`` babbles through it and ``facesynth plan --camera`` rehearses a plan through
it: the camera (sensor), the tracker (points), F on the robot's face (features, its neutral
learned while the babbler holds the head there) and the control interface with the servo
driver, built as ``facesynth run`` builds a graph's nodes; :func:`preflight` opens the servo
board once first, so a board that is not there is a clear error before anything starts.
"""

from __future__ import annotations

from typing import Any

import msgspec

from facesynth.app.graph import Graph
from facesynth.app.nodes import ControlNode, FeaturesNode, PointsNode, SensorNode
from facesynth.app.wiring import StageParts, build_node
from facesynth.runtime.profiles import Profile
from facesynth.services.control.drivers.registry import DRIVERS
from facesynth.services.sensor.sources.camera import CameraConfig

__all__ = ["build_parts", "newest", "preflight"]


def build_parts(
    profile_ref: str, rig: str, profile: Profile, configs: dict[str, msgspec.Struct]
) -> dict[str, StageParts]:
    """The robot's nodes (``configs``: the ``sensor``'s, ``points``' and ``control``'s; the
    control interface runs ``profile_ref``, a profile's name or path, loaded as ``profile``)."""
    source, backend, driver = configs["sensor"], configs["points"], configs["control"]
    nodes: dict[str, Any] = {
        # The robot's camera measures the face: its frames are never dropped for their age.
        "sensor": SensorNode(source=msgspec.to_builtins(source), capture_age=False),
        "points": PointsNode(backend=msgspec.to_builtins(backend), queue=1),
        "features": FeaturesNode(
            neutral_seconds=profile.neutral_seconds, keep_state=False, neutral_held=True
        ),
        "control": ControlNode(profile=profile_ref, driver=msgspec.to_builtins(driver)),
    }
    graph = Graph(rig=rig, nodes=nodes)
    return {name: build_node(name, node, graph, configs.get(name)) for name, node in nodes.items()}


def newest(source: msgspec.Struct) -> msgspec.Struct:
    """A camera that keeps only its newest frame: a pose's face is judged from frames taken
    after it was reached, so a frame that waited in the camera's stream must be dropped, not
    passed on as a new one (other sources as they are)."""
    if isinstance(source, CameraConfig):
        return msgspec.structs.replace(source, newest=True)
    return source


async def preflight(config: msgspec.Struct, profile: Profile) -> None:
    """Open the servo board once (a clear error if it is not there), then let it go."""
    driver = DRIVERS.build(config, profile)
    await driver.connect_once(query_only=True)
    await driver.close()
