"""services.sensor.service in virtual time: real-time pacing, the --fast credit window and its
ack timeout, waiting for the other services. Every time below is exact (a FakeClock)."""

from __future__ import annotations

import logging
from collections.abc import Iterator

import numpy as np
import pytest

from facesynth.runtime import keys
from facesynth.runtime.clock import FAKE_EPOCH_NS
from facesynth.runtime.clock_host import clock_host
from facesynth.runtime.testing import StageRun
from facesynth.schemas.messages import ServoCommands
from facesynth.services.sensor.service import SensorOptions, SensorService
from facesynth.services.sensor.sources import FrameSource, SourceInfo
from facesynth.services.sensor.sources.ticks import TicksConfig, TickSource

MS = 1_000_000


def ticks(count: int, fps: float = 30.0) -> TickSource:
    return TickSource(TicksConfig(count=count, fps=fps))


def sensor_run(source: FrameSource, **options: object) -> tuple[StageRun, SensorService]:
    sensor = SensorService(source, SensorOptions(**options))  # type: ignore[arg-type]
    return StageRun(sensor.serve, service="sensor"), sensor


def sent(run: StageRun) -> list[tuple[int, int]]:
    """``(seq, virtual time in ms)`` of every frame published so far."""
    return [(p.message.seq, p.t_ns // MS) for p in run.on("input")]


def ack(seq: int) -> ServoCommands:
    return ServoCommands(
        seq=seq, t_capture_ns=1, t_media_ns=1, face=True, profile="p", positions={}
    )


# --- real time -----------------------------------------------------------------------------------


async def test_frames_leave_at_the_recordings_pace() -> None:
    run, _ = sensor_run(ticks(5, 10.0))
    async with run:
        assert await run.finish(timeout=10.0) == 4
        assert sent(run) == [(0, 0), (1, 100), (2, 200), (3, 300), (4, 400)]
        frames = run.messages("input")
        assert [f.t_capture_ns for f in frames] == [FAKE_EPOCH_NS + i * 100 * MS for i in range(5)]
        assert [f.t_media_ns for f in frames] == [i * 100 * MS for i in range(5)]
        assert {(f.encoding, f.source, f.fps) for f in frames} == {("none", "ticks", 10.0)}


async def test_real_time_frames_name_this_host_as_their_capture_host_fast_ones_none() -> None:
    # Downstream stages age real-time frames from capture (and drop them after a stall);
    # --fast frames wait for credit by design and are never aged.
    run, _ = sensor_run(ticks(2, 10.0))
    async with run:
        await run.finish(timeout=10.0)
        assert {f.capture_host for f in run.messages("input")} == {clock_host()}
    run, _ = sensor_run(ticks(2, 10.0), fast=True, window=2)
    async with run:
        await run.finish(timeout=0.0)
        assert {f.capture_host for f in run.messages("input")} == {""}
    run, _ = sensor_run(ticks(2, 10.0), capture_age=False)  # a camera that only measures
    async with run:
        await run.finish(timeout=10.0)
        assert {f.capture_host for f in run.messages("input")} == {""}


class Stamped(FrameSource):
    """A live source that knows when each frame was captured, and on whose clock (``""``: this
    host's), as the ROS 2 source does."""

    def __init__(self, stamps: list[tuple[int | None, str]]) -> None:
        self.stamps = stamps
        self.info = SourceInfo("stamped", 10.0, None, live=True)
        self._last: tuple[int | None, str] = (None, "")

    def frames(self) -> Iterator[tuple[np.ndarray | None, int]]:
        for i, stamp in enumerate(self.stamps):
            self._last = stamp
            yield None, i * 100 * MS

    def capture_time_ns(self) -> int | None:
        return self._last[0]

    def capture_clock(self) -> str:
        return self._last[1]


async def test_a_frame_names_the_clock_its_source_read_its_capture_time_on() -> None:
    # A camera's stamp 3 s behind, on its own clock: named so, the stages downstream learn its
    # offset; a time the sensor read itself is this host's clock.
    behind = FAKE_EPOCH_NS - 3_000_000_000
    stamps = [(behind, "ros2:/camera"), (None, ""), (behind + 100 * MS, "ros2:/camera")]
    run, _ = sensor_run(Stamped(stamps))
    async with run:
        await run.finish(timeout=10.0)
        frames = [(f.t_capture_ns, f.capture_host) for f in run.messages("input")]
        assert frames == [
            (behind, "ros2:/camera"),
            (FAKE_EPOCH_NS, clock_host()),
            (behind + 100 * MS, "ros2:/camera"),
        ]
    run, _ = sensor_run(Stamped(stamps), fast=True, window=5)  # never aged: no clock named
    async with run:
        await run.finish(timeout=0.0)
        assert {f.capture_host for f in run.messages("input")} == {""}


class Replayed(FrameSource):
    """Ticks at given media times (a looped recording goes back to 0)."""

    def __init__(self, times_ms: list[int]) -> None:
        self.times_ms = times_ms
        self.info = SourceInfo("replayed", 10.0, len(times_ms), live=False)
        self.closed = False

    def frames(self) -> Iterator[tuple[np.ndarray | None, int]]:
        for t in self.times_ms:
            yield None, t * MS

    def close(self) -> None:
        self.closed = True


async def test_a_recording_that_wraps_around_starts_a_new_schedule() -> None:
    source = Replayed([0, 100, 200, 0, 100])
    run, _ = sensor_run(source)
    async with run:
        await run.finish(timeout=10.0)
        assert sent(run) == [(0, 0), (1, 100), (2, 200), (3, 200), (4, 300)]
        assert source.closed


async def test_max_frames_stops_early() -> None:
    run, sensor = sensor_run(ticks(100, 50.0), max_frames=3)
    async with run:
        assert await run.finish(timeout=10.0) == 2
        assert sent(run) == [(0, 0), (1, 20), (2, 40)] and sensor.last_seq == 2


# --- --fast: the credit window ---------------------------------------------------------------


async def test_fast_keeps_at_most_window_frames_ahead_of_the_last_command() -> None:
    run, _ = sensor_run(ticks(6, 1.0), fast=True, window=2)
    async with run:
        assert sent(run) == [(0, 0), (1, 0)]  # two frames in flight before any result
        await run.advance(0.1)
        await run.send("servo_commands", ack(0))
        assert sent(run)[2:] == [(2, 100)]
        await run.advance(0.1)
        await run.send("servo_commands", ack(3))  # results may skip frames
        assert sent(run)[3:] == [(3, 200), (4, 200), (5, 200)]
        assert await run.finish(timeout=0.0) == 5


async def test_a_result_that_never_comes_costs_exactly_ack_timeout_then_the_sensor_sends_on(
    caplog: pytest.LogCaptureFixture,
) -> None:
    run, sensor = sensor_run(ticks(4, 1000.0), fast=True, window=1, ack_timeout=2.0)
    with caplog.at_level(logging.WARNING, logger="facesynth.sensor"):
        async with run:
            assert sent(run) == [(0, 0)]
            await run.advance(2.0 - 1e-9)
            assert sent(run) == [(0, 0)]
            await run.finish(timeout=10.0)
    assert sent(run) == [(0, 0), (1, 2000), (2, 4000), (3, 6000)]
    assert sensor.stalls == 3
    assert "no servo command for frame 0 after 2.0 s: sending on" in caplog.text


async def test_a_late_result_still_opens_the_window_before_the_timeout() -> None:
    run, sensor = sensor_run(ticks(2, 1000.0), fast=True, window=1, ack_timeout=2.0)
    async with run:
        await run.advance(1.5)
        await run.send("servo_commands", ack(0))
        assert sent(run) == [(0, 0), (1, 1500)] and sensor.stalls == 0


async def test_undecodable_results_are_ignored() -> None:
    run, _ = sensor_run(ticks(2, 1000.0), fast=True, window=1, ack_timeout=1.0)
    async with run:
        await run.send("servo_commands", b"\x00not msgpack")
        await run.advance(0.5)
        assert sent(run) == [(0, 0)]
        await run.send("servo_commands", ack(0))
        assert sent(run) == [(0, 0), (1, 500)]


async def test_with_a_control_interface_alive_credit_comes_from_what_it_applied() -> None:
    run, _ = sensor_run(ticks(2, 1000.0), fast=True, window=1, ack_timeout=5.0)
    run.network.bus().declare_token(keys.health_key(run.rig, "control", "c1"))
    async with run:
        await run.send("servo_commands", ack(0))  # commanded, not applied: no credit
        assert sent(run) == [(0, 0)]
        await run.advance(0.3)
        await run.send("servo_state", ack(0))
        assert sent(run) == [(0, 0), (1, 300)]


# --- waiting for the chain -----------------------------------------------------------------


async def test_waits_for_the_named_services_then_starts() -> None:
    run, _ = sensor_run(ticks(1), wait_for=["points"], wait_timeout=10.0)
    async with run:
        await run.advance(0.3)
        assert sent(run) == []
        run.network.bus().declare_token(keys.health_key(run.rig, "points", "p1"))
        await run.advance(0.05)  # the next look, 50 ms after the last
        assert sent(run) == [(0, 350)]


async def test_gives_up_waiting_after_wait_timeout(caplog: pytest.LogCaptureFixture) -> None:
    run, _ = sensor_run(ticks(1), wait_for=["points", "features"], wait_timeout=1.0)
    with caplog.at_level(logging.WARNING, logger="facesynth.sensor"):
        async with run:
            await run.finish(timeout=5.0)
    assert sent(run) == [(0, 1000)]
    assert "still waiting for ['features', 'points'] after 1.0 s: starting anyway" in caplog.text


async def test_stats_go_out_every_stats_interval() -> None:
    run, _ = sensor_run(ticks(30, 10.0))
    async with run:
        await run.finish(timeout=10.0)  # the last frame leaves at 2.9 s and the sensor ends
    stats = run.on("stats")
    assert [p.t_ns // MS for p in stats] == [1000, 2000, 2900]
    assert stats[-1].message.note == "stopped" and stats[-1].message.published == 30
    assert stats[0].key == keys.stats_key(run.rig, "sensor", "one")
