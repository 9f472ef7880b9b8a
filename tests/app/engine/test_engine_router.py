"""The engine's buses: an embedded router's stages report no router link (they are on the
router), a joined session reports the link it has, and every command opens its embedded router
through the engine (a hand-made copy once left ``replay --graph``'s stages reporting "down")."""

from __future__ import annotations

import asyncio
import json
import re
from pathlib import Path

from facesynth_processes import Processes, free_port, run_facesynth

from facesynth.app.engine.router import embedded_bus, joined_bus
from facesynth.runtime.bus.zenoh_bus import ZenohOptions

ROOT = Path(__file__).resolve().parents[3]
CSV = ROOT / "facesynth" / "app" / "data" / "OpenFace_Test.csv"


async def test_an_embedded_bus_is_the_router_and_a_joined_client_links_to_it() -> None:
    options = ZenohOptions(mode="router")
    async with embedded_bus(["tcp/127.0.0.1:0"], options, rig="engine") as (router, locators):
        assert router.link() is None, "the router's own session has no router to link to"
        assert locators and all(loc.startswith("tcp/127.0.0.1:") for loc in locators)
        client = ZenohOptions(mode="client", connect=locators)
        async with joined_bus(client) as bus:
            for _ in range(100):
                link = bus.link()
                if link is not None and link.connected:
                    break
                await asyncio.sleep(0.02)
            assert link is not None and link.connected


def test_only_the_engine_opens_an_embedded_router() -> None:
    copies = [
        str(path.relative_to(ROOT))
        for path in sorted((ROOT / "facesynth").rglob("*.py"))
        if path.parent.name != "engine" and re.search(r"\bopen_embedded\b", path.read_text())
    ]
    assert not copies, f"open an embedded router with facesynth.app.engine.router: {copies}"


def test_replay_through_a_graph_reports_its_stages_on_the_router(
    tmp_path: Path, processes: Processes
) -> None:
    session = tmp_path / "s.mcap"
    live = run_facesynth(
        "run", "--openface-csv", str(CSV), "--listen", "tcp/127.0.0.1:0", "--fast",
        "--out", str(tmp_path / "live.jsonl"), "--record", str(session),
    )  # fmt: skip
    assert live.returncode == 0, live.stderr
    port = free_port()
    processes(
        "replay", str(session), "--from", "features", "--graph", "--speed", "0.04",
        "--listen", f"tcp/127.0.0.1:{port}", "--stats-interval", "0.2",
        "--out", str(tmp_path / "replayed.jsonl"),
        name="replay",
    )  # fmt: skip
    processes.wait_for_line("replay", "replaying features")
    status = run_facesynth(
        "status", "--connect", f"tcp/127.0.0.1:{port}", "--mode", "client", "--timeout", "1.5"
    )
    assert status.returncode == 0, status.stderr + status.stdout
    rows = {
        fields[1]: fields
        for line in status.stdout.splitlines()[1:]
        if len(fields := line.split()) > 2 and fields[1] in {"translator", "control", "replay"}
    }
    assert set(rows) == {"translator", "control", "replay"}, status.stdout
    for service, fields in rows.items():
        claimed = {"up", "down", "up,", "down,"} & set(fields)
        assert not claimed, f"{service} claims a router link:\n{status.stdout}"
    replayed = json.loads(processes.wait_for_line("replay", '"published"', timeout=60))
    assert replayed["published"] == 100
