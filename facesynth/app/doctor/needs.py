"""What a configured graph needs from the host, read from its nodes and plugin configs (pure).

The graph is the one ``facesynth run`` would run with the same arguments (its flags applied,
its profiles settled): its cameras, its boards' serial ports, the files it writes, the named
files it reads, the extras its plugins import, and its link to a Zenoh router.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import msgspec

from facesynth.app.graph import PLUGIN_TABLES, Graph
from facesynth.app.nodes import ControlNode, FeaturesNode, TranslatorNode, stage_of
from facesynth.runtime.bus.zenoh_bus import ZenohOptions
from facesynth.services.features.state import default_state_dir

#: The board drivers that talk over a serial port, and the board each expects to answer.
SERIAL_DRIVERS = {"arduino": "firmware", "maestro": "maestro", "ssc32": "ssc32"}


@dataclass(frozen=True)
class SerialNeed:
    """A board the graph drives: its node, driver, port and baud rate."""

    node: str
    driver: str
    port: str
    baud: int
    #: A Maestro in "UART, detect baud rate" mode: it answers after the baud-rate byte.
    detect_baud: bool = False


@dataclass(frozen=True)
class RouterNeed:
    """The graph's link to Zenoh: its own router listening (``run``'s default), or a client
    of a router elsewhere (``--mode client --connect …``, a config file)."""

    options: ZenohOptions
    embedded: bool
    #: ``run``'s own router takes a free port on loopback when its endpoint is taken (its
    #: default endpoint, with a sensor in the graph); an explicit ``--listen`` is kept or fails.
    free_port: bool = False


@dataclass
class Needs:
    """Everything the graph needs, each with the node (or option) that needs it."""

    cameras: list[tuple[str, int | str]] = field(default_factory=list)
    serial: list[SerialNeed] = field(default_factory=list)
    outputs: list[tuple[str, Path]] = field(default_factory=list)
    folders: list[tuple[str, Path]] = field(default_factory=list)
    profiles: list[tuple[str, str, msgspec.Struct | None]] = field(default_factory=list)
    calibrations: list[tuple[str, str]] = field(default_factory=list)
    extras: dict[str, list[str]] = field(default_factory=dict)
    #: ``(who, HOST:PORT, the flag that changes it)`` of every server the graph starts.
    addresses: list[tuple[str, str, str]] = field(default_factory=list)
    router: RouterNeed | None = None

    def need_extra(self, extra: str, who: str) -> None:
        """Note that ``who`` imports the packages of ``extra``."""
        whom = self.extras.setdefault(extra, [])
        if who not in whom:
            whom.append(who)


def plugin_extra(stage: str, config: msgspec.Struct | None) -> str | None:
    """The extra a plugin config's class imports when built (its ``needs_extra``)."""
    table = PLUGIN_TABLES.get(stage)
    if table is None or config is None:
        return None
    plugin = table[1].get(str(config.__struct_config__.tag))
    return getattr(plugin.factory, "needs_extra", None)


def graph_needs(
    graph: Graph, configs: dict[str, Any], *, router: RouterNeed | None, options: Any
) -> Needs:
    """The needs of a settled graph; ``configs`` are its nodes' validated plugin configs and
    ``options`` the command line (``--record``, ``--render``, ``--foxglove``)."""
    needs = Needs(router=router)
    for name, node in graph.nodes.items():
        stage = stage_of(node)
        config = configs.get(name)
        extra = plugin_extra(stage, config)
        if extra is not None and config is not None:
            needs.need_extra(extra, f"{stage} node {name} ({config.__struct_config__.tag})")
        tag = config.__struct_config__.tag if config is not None else None
        if stage == "sensor" and tag == "camera":
            needs.cameras.append((name, getattr(config, "index", 0)))
        if isinstance(node, ControlNode):
            if tag in SERIAL_DRIVERS:
                port = getattr(config, "port", "")
                baud, detect = getattr(config, "baud", 0), getattr(config, "detect_baud", False)
                needs.serial.append(SerialNeed(name, str(tag), port, baud, detect))
            http = getattr(config, "http", None)
            if tag == "virtual" and http:
                needs.addresses.append((f"control node {name}'s live page", http, "--http"))
            out = getattr(config, "out", None)
            if tag == "record" and out:
                needs.outputs.append((f"control node {name}'s record file", Path(out)))
        if isinstance(node, ControlNode | TranslatorNode) and node.profile is not None:
            driver = config if isinstance(node, ControlNode) else None
            needs.profiles.append((name, node.profile, driver))
        if isinstance(node, FeaturesNode | TranslatorNode) and node.calibration:
            needs.calibrations.append((name, node.calibration))
        if isinstance(node, FeaturesNode) and not node.calibration and node.keep_state:
            folder = Path(node.state_dir) if node.state_dir else default_state_dir()
            needs.folders.append((f"features node {name}'s kept state", folder))
    record = getattr(options, "record", None)
    if record:
        needs.outputs.append(("--record session", Path(record)))
        needs.need_extra("record", "--record")
    foxglove = getattr(options, "foxglove", None)
    if foxglove:
        needs.need_extra("record", "--foxglove")
        needs.addresses.append(("--foxglove live view", foxglove, "--foxglove"))
    render = getattr(options, "render", None)
    if render:
        needs.outputs.append(("--render video", Path(render)))
        needs.need_extra("tracker", "--render")
    return needs
