"""The service runtime and shells on the in-memory bus: counting, rejecting, neutral on silence."""

from __future__ import annotations

import asyncio
import contextlib
import itertools
from collections.abc import Mapping
from typing import Any

import pytest

from facesynth.runtime import codec, keys
from facesynth.runtime.bus.memory import MemoryNetwork
from facesynth.runtime.profiles import load_profile
from facesynth.runtime.service import ServiceContext, run_service, serve_transform
from schemas.messages import Features, Points, ServiceStats, ServoCommands
from services.control.core import CommandInfo
from services.control.drivers.base import ServoDriver
from services.control.service import ControlService
from services.features.core import FeatureProcessor
from services.features.service import serve_features

RIG = "unit"


class ListDriver(ServoDriver):
    """Keeps what it was sent (a test double at the driver seam, not a mock of facesynth code)."""

    def __init__(self) -> None:
        self.sent: list[tuple[dict[str, float], CommandInfo]] = []
        self.connected = False
        self.closed = False

    async def connect(self) -> None:
        self.connected = True

    async def send(self, positions: Mapping[str, float], info: CommandInfo) -> None:
        self.sent.append((dict(positions), info))

    async def close(self) -> None:
        self.closed = True


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


async def test_stats_are_published_periodically() -> None:
    network = MemoryNetwork()
    bus = network.bus()
    stats_sub = bus.subscribe_queued(keys.stats_pattern(RIG), 16)
    ctx = ServiceContext(bus, RIG, "features", instance="one", stats_interval=0.05)
    task = asyncio.create_task(run_service(ctx, lambda c: serve_features(c, FeatureProcessor(), 8)))
    sample = await asyncio.wait_for(stats_sub.receive(), 2)
    assert sample.key == keys.stats_key(RIG, "features", "one")
    stats = codec.decode(sample.payload, ServiceStats)
    assert stats.service == "features" and stats.rss_mb > 0
    task.cancel()
    with contextlib.suppress(asyncio.CancelledError):
        await task


def _commands(seq: int, **positions: float) -> bytes:
    return codec.encode(
        ServoCommands(
            seq=seq, t_capture_ns=1, t_media_ns=1, face=True, profile="paper16", positions=positions
        )
    )


async def test_control_clamps_rejects_and_returns_to_neutral_on_silence() -> None:
    network = MemoryNetwork()
    bus = network.bus()
    driver = ListDriver()
    control = ControlService(load_profile("paper16"), driver, watchdog_s=0.1)
    ctx = ServiceContext(bus, RIG, "control")
    task = asyncio.create_task(run_service(ctx, control.serve))
    await _until(lambda: bool(network.tokens))
    assert driver.connected and driver.sent[0][0]["jaw"] == 1500.0  # starts at neutral
    key = keys.stage_key(RIG, "servo_commands")
    bus.publish(key, _commands(0, jaw=2600.0, right_eyebrow=900.0))
    bus.publish(key, _commands(1, tail=1500.0))  # unknown servo: refused whole
    bus.publish(key, b"\x93garbage")
    await _until(lambda: ctx.stats.rejected == 2)
    moved = [positions for positions, info in driver.sent if info.frame == 0]
    assert moved == [
        {**load_profile("paper16").neutral_positions(), "jaw": 2000.0, "right_eyebrow": 1000.0}
    ]
    await _until(lambda: set(driver.sent[-1][0].values()) == {1500.0} and len(driver.sent) >= 3)
    # The return to neutral is a ramp (paper16: neutral_ramp_s 0.5), not a jump.
    ramp = [positions["jaw"] for positions, info in driver.sent if info.frame is None][1:]
    assert len(ramp) > 3, ramp
    assert all(a > b for a, b in itertools.pairwise(ramp)), ramp
    assert ramp[0] < 2000.0 and ramp[-1] == 1500.0
    count = len(driver.sent)
    await asyncio.sleep(0.3)
    assert len(driver.sent) == count, "the watchdog fires once per silence"
    task.cancel()
    with contextlib.suppress(asyncio.CancelledError):
        await task
    assert driver.closed and set(driver.sent[-1][0].values()) == {1500.0}


@pytest.mark.parametrize("bad", ["", "a/b", "x*", "a" * 65])
def test_context_refuses_bad_names(bad: str) -> None:
    with pytest.raises(ValueError, match="invalid"):
        ServiceContext(MemoryNetwork().bus(), bad, "features")
