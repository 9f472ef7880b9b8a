"""`facesynth run` of the face graph as a process: a page sees the real chain's face, the
performer's frames and landmarks, and every stage's stats."""

from __future__ import annotations

import asyncio
import json
import signal
import socket

import aiohttp

from facesynth.app.graph import GRAPHS_DIR
from facesynth.services.control.drivers.virtual import wire


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


async def test_a_page_watches_the_running_chain(spawn) -> None:  # type: ignore[no-untyped-def]
    port = _free_port()
    proc = spawn(
        "run", str(GRAPHS_DIR / "face.toml"), "--http", f"127.0.0.1:{port}",
        "--listen", "tcp/127.0.0.1:0", name="run",
    )  # fmt: skip
    got: dict[str, object] = {}
    services: set[str] = set()
    async with aiohttp.ClientSession() as session:
        ws = None
        for _ in range(300):  # the tracker's models load first
            try:
                ws = await session.ws_connect(f"http://127.0.0.1:{port}/ws")
                break
            except aiohttp.ClientError:
                assert proc.poll() is None, spawn.log("run")
                await asyncio.sleep(0.1)
        assert ws is not None, spawn.log("run")
        loop = asyncio.get_running_loop()
        deadline = loop.time() + 60
        while loop.time() < deadline and not (
            {"hello", "frame", "points", "face"} <= set(got) and len(services) == 5
        ):
            msg = await ws.receive(timeout=max(0.1, deadline - loop.time()))
            if msg.type == aiohttp.WSMsgType.BINARY:
                got["frame"] = wire.read_frame(msg.data)[0]
                continue
            data = json.loads(msg.data)
            if data["type"] == "face" and not (data["face"] and data["seq"] is not None):
                continue  # the neutral sent at start
            if data["type"] == "points" and not data["face"]:
                continue
            got[data["type"]] = data
            if data["type"] == "stats":
                services |= {
                    row["service"] for row in data["services"] if row["status"] == "running"
                }
        await ws.close()
    assert services == {"sensor", "points", "features", "translator", "control"}, spawn.log("run")
    assert got["hello"]["profile"] == "virtual"  # type: ignore[index]
    assert got["frame"]["width"] == 640 and got["frame"]["encoding"] == "jpeg"  # type: ignore[index]
    assert len(got["points"]["ibug68"]) == 136  # type: ignore[index]
    face = got["face"]
    assert face["shapes"][0]["name"] == "head" and "jaw" in face["controls"]  # type: ignore[index]
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=20) in (0, 130), spawn.log("run")
