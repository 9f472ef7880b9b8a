"""A console on an in-memory bus: C with the record driver, the session and the server."""

from __future__ import annotations

import shutil
from collections.abc import AsyncIterator
from pathlib import Path

import msgspec
import pytest
from console_token import TOKEN

from facesynth.app.console.rig import ConsoleRig
from facesynth.app.console.server import ConsoleServer
from facesynth.app.console.session import ConsoleSession
from facesynth.app.graph import Graph
from facesynth.app.nodes import ControlNode
from facesynth.app.wiring import StageParts, build_node
from facesynth.runtime.bus.memory import MemoryNetwork
from facesynth.runtime.profiles import PACKAGE_DIR, load_profile
from facesynth.services.control.drivers.record import RecordConfig


@pytest.fixture
async def console(tmp_path: Path) -> AsyncIterator[ConsoleServer]:
    """A running console for ``tmp_path/head.toml`` (a copy of head16_hardware); C records
    what it sends the servos to ``tmp_path/commands.jsonl``."""
    path = tmp_path / "head.toml"
    shutil.copy(Path(PACKAGE_DIR) / "head16_hardware.toml", path)
    bus = MemoryNetwork().bus()
    config = RecordConfig(out=str(tmp_path / "commands.jsonl"))
    node = ControlNode(profile=str(path), driver=msgspec.to_builtins(config))
    graph = Graph(rig="t", nodes={"control": node})

    def control(profile_file: str) -> StageParts:
        return build_node("control", msgspec.structs.replace(node, profile=profile_file), graph)

    core = ConsoleRig(load_profile(str(path)))
    session = ConsoleSession(bus, "t", core, control, profile_file=str(path), save_to=path)
    server = ConsoleServer(session, host="127.0.0.1", port=0, token=TOKEN)
    await server.start()
    await session.start()
    try:
        yield server
    finally:
        await server.stop()
        await session.stop()
        await bus.close()
