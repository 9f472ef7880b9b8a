"""CPU per message handed from one stage to the next within a process (issue 28).

    python tools/handover_cpu.py [--messages 2000] [--rounds 2] [--bus memory,router]

Times ``ServiceContext.publish`` → ``ctx.subscribe(stage, …, type)`` → ``receive`` for a
Points message of the ``full`` tracker (ibug68, mesh478, iris10, blendshapes52), a Features
message (68 distances, deltas, 136 displacements, every named feature, named and raw) and a
ServoCommands message of 16 servos, on an in-memory bus and on a Zenoh router session like
``facesynth run``'s (the message object is handed over, nothing encoded: no subscriber
elsewhere). Each message is a new object, so every one is checked (``codec.check``). CPU is
this process's user + system time over ``--messages`` messages, published and received one by
one, after 200 unmeasured ones; prints µs per message for each run.

To compare two trees, run it with ``PYTHONPATH`` set to each tree in turn, interleaved.
"""

from __future__ import annotations

import argparse
import asyncio
import time
from collections.abc import Callable
from typing import Any

import msgspec

from facesynth.app.engine.router import open_embedded
from facesynth.runtime import blendshapes, feature_names, keys
from facesynth.runtime.bus.base import Bus
from facesynth.runtime.bus.memory import MemoryNetwork
from facesynth.runtime.bus.zenoh_bus import ZenohBus, ZenohOptions
from facesynth.runtime.service import ServiceContext
from facesynth.schemas.messages import Features, Points, PointSet, ScoreSet, ServoCommands

RIG = "handover"
WARMUP = 200


def _points() -> Points:
    return Points(
        seq=0,
        t_capture_ns=1,
        t_media_ns=1,
        face=True,
        confidence=0.98,
        image_width=640,
        image_height=360,
        sets=[
            PointSet(scheme="ibug68", dims=2, coords=[100.0 + i * 0.5 for i in range(136)]),
            PointSet(scheme="mesh478", dims=3, coords=[50.0 + i * 0.25 for i in range(1434)]),
            PointSet(scheme="iris10", dims=2, coords=[200.0 + i for i in range(20)]),
        ],
        scores=[ScoreSet(scheme=blendshapes.BLENDSHAPES52, values=[0.25] * blendshapes.COUNT)],
        source="tracker",
    )


def _features() -> Features:
    named = {name: 0.125 for name in feature_names.NAMES}
    return Features(
        seq=0,
        t_capture_ns=1,
        t_media_ns=1,
        face=True,
        neutral_ready=True,
        distances=[1.0 + i / 68 for i in range(68)],
        deltas=[0.01 * i for i in range(68)],
        named=named,
        raw=dict(named),
        displacements=[0.001 * i for i in range(136)],
    )


def _commands() -> ServoCommands:
    return ServoCommands(
        seq=0,
        t_capture_ns=1,
        t_media_ns=1,
        face=True,
        profile="paper16",
        positions={f"servo{i}": 1500.0 + i for i in range(16)},
        sender="translator-1",
        sender_seq=1,
        sent_ns=1,
        sender_host="host",
    )


MESSAGES: dict[str, tuple[keys.Stage, type[Any], Callable[[], msgspec.Struct]]] = {
    "Points": ("points", Points, _points),
    "Features": ("features", Features, _features),
    "ServoCommands": ("servo_commands", ServoCommands, _commands),
}


async def _handover_us(bus: Bus, name: str, count: int) -> float:
    """µs of CPU per message handed over ``count`` times on ``bus``."""
    stage, cls, make = MESSAGES[name]
    sender = ServiceContext(bus, RIG, "sender", instance="sender-1", stats_interval=3600)
    reader = ServiceContext(bus, RIG, "reader", instance="reader-1", stats_interval=3600)
    subscription = reader.subscribe(stage, 4, cls)
    base = make()
    messages = [msgspec.structs.replace(base, seq=i) for i in range(WARMUP + count)]
    started = 0.0
    for index, message in enumerate(messages):
        if index == WARMUP:
            started = time.process_time()
        sender.publish(stage, message)
        sample = await subscription.receive()
        assert sample.message is message, "the object was not handed over"
    spent = time.process_time() - started
    subscription.close()
    return spent / count * 1e6


async def _on(kind: str, name: str, count: int) -> float:
    if kind == "memory":
        return await _handover_us(MemoryNetwork().bus(), name, count)
    session, _ = open_embedded(["tcp/127.0.0.1:0"], ZenohOptions(), fallback=False)
    bus = ZenohBus(session, mode="router")
    try:
        return await _handover_us(bus, name, count)
    finally:
        await bus.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--messages", type=int, default=2000)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--bus", default="memory,router")
    args = parser.parse_args()
    for round_ in range(args.rounds):
        for kind in args.bus.split(","):
            for name in MESSAGES:
                us = asyncio.run(_on(kind, name, args.messages))
                print(f"round {round_ + 1} {kind:<6} {name:<13} {us:8.1f} µs/message", flush=True)


if __name__ == "__main__":
    main()
