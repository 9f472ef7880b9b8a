"""The live view speaks Foxglove's WebSocket protocol: a real client subscribes and receives."""

from __future__ import annotations

import asyncio
import base64
import json
import time
from pathlib import Path

import aiohttp
import pytest
from facesynth_processes import Processes
from foxglove_client import FoxgloveClient, connect
from mcap.records import Schema
from mcap_protobuf.decoder import DecoderFactory
from messages_sample import jpeg, messages

from facesynth.app.recording.live import Address, FoxgloveBridge, LiveViewError
from facesynth.runtime.bus.zenoh_bus import ZenohBus, ZenohOptions


def _protobuf(channel: dict[str, object], payload: bytes) -> object:
    schema = Schema(
        id=1,
        name=str(channel["schemaName"]),
        encoding="protobuf",
        data=base64.b64decode(str(channel["schema"])),
    )
    decoder = DecoderFactory().decoder_for("protobuf", schema)
    assert decoder is not None
    return decoder(payload)


async def _receive(client: FoxgloveClient, wanted: set[int]) -> dict[int, bytes]:
    got: dict[int, bytes] = {}
    while set(got) != wanted:
        subscription, _, payload = await client.message()
        assert subscription in wanted, "only subscribed channels are sent"
        got.setdefault(subscription, payload)
    return got


async def test_a_client_subscribes_and_receives_json_images_and_landmarks(rig: str) -> None:
    bridge = FoxgloveBridge(Address("127.0.0.1", 0))
    bridge.start()
    try:
        for key, payload in messages(0, rig):
            bridge.show(key, payload, time.time_ns())
        async with aiohttp.ClientSession() as http:
            client = await connect(http, bridge.url)
            state = await client.wait_for_channel(f"/facesynth/{rig}/servo_state")
            image = await client.wait_for_channel(f"/facesynth/{rig}/input/image")
            marks = await client.wait_for_channel(f"/facesynth/{rig}/points/annotations")
            stats = await client.wait_for_channel(f"/facesynth/{rig}/stats/features/host-1")
            assert (state["encoding"], state["schemaName"]) == ("json", "facesynth.ServoCommands")
            assert json.loads(state["schema"])["title"] == "ServoCommands"
            assert (
                image["schemaName"] == "foxglove.CompressedImage"
                and image["encoding"] == "protobuf"
            )
            ids = {
                name: await client.subscribe(ch)
                for name, ch in (
                    ("state", state),
                    ("image", image),
                    ("marks", marks),
                    ("stats", stats),
                )
            }
            await asyncio.sleep(0.3)
            for key, payload in messages(1, rig):
                bridge.show(key, payload, time.time_ns())
            got = await _receive(client, set(ids.values()))
            await client.close()
    finally:
        bridge.stop()
    applied = json.loads(got[ids["state"]])
    assert (applied["seq"], applied["positions"]["jaw"]) == (1, 1500.125)
    picture = _protobuf(image, got[ids["image"]])
    assert (picture.format, bytes(picture.data)) == ("jpeg", jpeg())  # type: ignore[attr-defined]
    assert len(_protobuf(marks, got[ids["marks"]]).points) == 10  # type: ignore[attr-defined]
    assert json.loads(got[ids["stats"]])["latency_p50_ms"] == 1.25


def test_addresses_are_checked() -> None:
    assert Address.parse("0.0.0.0:9000") == Address("0.0.0.0", 9000)
    assert Address.parse(":0") == Address("127.0.0.1", 0)
    assert Address.parse("localhost") == Address("localhost", 8765)
    for bad in ("host:port", "127.0.0.1:70000"):
        with pytest.raises(LiveViewError):
            Address.parse(bad)


def test_a_taken_port_is_a_clear_error() -> None:
    first = FoxgloveBridge(Address("127.0.0.1", 0))
    port = first.start()
    try:
        with pytest.raises(LiveViewError, match=f"cannot serve Foxglove on 127.0.0.1:{port}"):
            FoxgloveBridge(Address("127.0.0.1", port)).start()
    finally:
        first.stop()


async def test_inspect_serves_a_running_rig(
    processes: Processes, zenoh_router: str, rig: str, tmp_path: Path
) -> None:
    processes.start(
        "inspect",
        "--mode",
        "client",
        "--connect",
        zenoh_router,
        "--rig",
        rig,
        "--foxglove",
        "127.0.0.1:0",
        name="inspect",
    )
    line = processes.wait_for_line("inspect", "ws://")
    url = next(word for word in line.split() if word.startswith("ws://"))
    bus = ZenohBus.open(ZenohOptions(mode="client", connect=[zenoh_router]))
    try:
        async with aiohttp.ClientSession() as http:
            client = await connect(http, url)
            # The rig's channels are there from the start, before any message.
            state = await client.wait_for_channel(f"/facesynth/{rig}/servo_state", timeout=30)
            subscription = await client.subscribe(state)
            received = None
            for seq in range(600, 1200):  # until inspect listens on the bus (bounded: ~60 s)
                for key, payload in messages(seq, rig):
                    bus.publish(key, payload)
                try:
                    sub, _, received = await client.message(timeout=0.1)
                    assert sub == subscription
                    break
                except TimeoutError:
                    continue
            assert received is not None
            assert json.loads(received)["seq"] >= 600
            await client.close()
    finally:
        await bus.close()


async def test_a_rigs_channels_are_there_before_any_message(rig: str) -> None:
    bridge = FoxgloveBridge(Address("127.0.0.1", 0), rig=rig)
    bridge.start()
    try:
        async with aiohttp.ClientSession() as http:
            client = await connect(http, bridge.url)
            for topic in (
                "input",
                "input/image",
                "points",
                "points/annotations",
                "features",
                "servo_commands",
                "servo_state",
            ):
                await client.wait_for_channel(f"/facesynth/{rig}/{topic}", timeout=5)
            subscription = await client.subscribe(client.channels[f"/facesynth/{rig}/servo_state"])
            await asyncio.sleep(0.3)
            key, payload = messages(5, rig)[7]
            bridge.show(key, payload, time.time_ns())
            sub, _, data = await client.message()
            assert sub == subscription and json.loads(data)["seq"] == 5
            await client.close()
    finally:
        bridge.stop()
