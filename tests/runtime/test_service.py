"""The service runtime on the in-memory bus: transforming, counting, rejecting, naming."""

from __future__ import annotations

import asyncio
import contextlib
from typing import Any

import pytest

from facesynth.runtime import codec, keys
from facesynth.runtime.bus.memory import MemoryNetwork
from facesynth.runtime.service import ServiceContext, run_service, serve_transform
from facesynth.schemas.messages import Features, Points
from facesynth.services.features.core import FeatureProcessor
from facesynth.services.features.service import serve_features

RIG = "unit"


async def _until(predicate: Any, timeout: float = 3.0) -> None:
    for _ in range(int(timeout / 0.01)):
        if predicate():
            return
        await asyncio.sleep(0.01)
    raise AssertionError("condition not reached")


def _no_face_points(seq: int) -> Points:
    return Points(
        seq=seq, t_capture_ns=1, t_media_ns=seq, face=False, image_width=640, image_height=480
    )


async def test_transform_publishes_results_and_rejects_bad_input() -> None:
    network = MemoryNetwork()
    service_bus, probe = network.bus(), network.bus()
    out = probe.subscribe_queued(keys.stage_key(RIG, "features"), 16)
    ctx = ServiceContext(service_bus, RIG, "features")
    task = asyncio.create_task(run_service(ctx, lambda c: serve_features(c, FeatureProcessor(), 8)))
    await _until(lambda: bool(network.tokens))
    probe.publish(keys.stage_key(RIG, "points"), b"not msgpack")
    probe.publish(keys.stage_key(RIG, "points"), codec.encode(_no_face_points(7)))
    features = codec.decode((await asyncio.wait_for(out.receive(), 2)).payload, Features)
    assert (features.seq, features.face) == (7, False)
    assert ctx.stats.received == 2 and ctx.stats.rejected == 1 and ctx.stats.published == 1
    task.cancel()
    with contextlib.suppress(asyncio.CancelledError):
        await task
    assert network.tokens == {}


async def test_transform_survives_an_internal_error() -> None:
    network = MemoryNetwork()
    bus = network.bus()
    ctx = ServiceContext(bus, RIG, "features")
    calls: list[int] = []

    def flaky(points: Points) -> Features:
        calls.append(points.seq)
        if points.seq == 0:
            raise IndexError("bug")
        return Features(seq=points.seq, t_capture_ns=1, t_media_ns=1, face=False)

    task = asyncio.create_task(serve_transform(ctx, "points", Points, "features", flaky, 8))
    await _until(lambda: bool(network.tokens))
    for seq in (0, 1):
        bus.publish(keys.stage_key(RIG, "points"), codec.encode(_no_face_points(seq)))
    await _until(lambda: ctx.stats.published == 1)
    assert calls == [0, 1] and ctx.stats.rejected == 1
    task.cancel()
    with contextlib.suppress(asyncio.CancelledError):
        await task


@pytest.mark.parametrize("bad", ["", "a/b", "x*", "a" * 65])
def test_context_refuses_bad_names(bad: str) -> None:
    with pytest.raises(ValueError, match="invalid"):
        ServiceContext(MemoryNetwork().bus(), bad, "features")


def test_a_robot_context_keys_only_the_command_and_state_stages_by_robot() -> None:
    ctx = ServiceContext(MemoryNetwork().bus(), RIG, "translator", robot="head2")
    assert ctx.key("servo_commands") == f"facesynth/{RIG}/servo_commands/head2"
    assert ctx.key("servo_state") == f"facesynth/{RIG}/servo_state/head2"
    assert ctx.key("features") == f"facesynth/{RIG}/features"  # the performer's, shared
    plain = ServiceContext(MemoryNetwork().bus(), RIG, "translator")
    assert plain.key("servo_commands") == f"facesynth/{RIG}/servo_commands"


@pytest.mark.parametrize("bad", ["", "a/b", "r*", "a" * 65])
def test_context_refuses_bad_robot_names(bad: str) -> None:
    with pytest.raises(ValueError, match="invalid robot name"):
        ServiceContext(MemoryNetwork().bus(), RIG, "control", robot=bad)
