"""Run one stage's service on the in-memory bus, in virtual time, and see what it publishes.

For tests of service shells (sensor, points, features, translator, control, or any body a
:class:`~facesynth.runtime.service.ServiceContext` runs)::

    control = ControlService(profile, driver, watchdog_s=0.5)
    async with StageRun(control.serve, service="control") as run:
        await run.send("servo_commands", commands)          # at virtual time 0
        await run.advance(0.5)                               # the watchdog fires at exactly 0.5 s
        assert run.messages("servo_state")[0].positions == ...

The stage runs under :func:`~facesynth.runtime.service.run_service` (liveliness token, periodic
stats) with a :class:`~facesynth.runtime.clock.FakeClock`: nothing happens between two instants
unless the test moves time (:meth:`StageRun.advance`, :meth:`StageRun.run_until`), and every
publication is recorded with the virtual time it was made at, decoded by its key
(:attr:`StageRun.published`). Tests take milliseconds whatever the timeouts they exercise.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable
from dataclasses import dataclass
from types import TracebackType
from typing import Any, Self

import msgspec

from facesynth.runtime import codec, keys
from facesynth.runtime.bus.base import Subscription
from facesynth.runtime.bus.memory import MemoryNetwork
from facesynth.runtime.clock import FakeClock, IdleTimeout, wall_offset_ns
from facesynth.runtime.service import Body, ServiceContext, run_service
from facesynth.schemas.messages import Features, Frame, Points, ServiceStats, ServoCommands

#: The message type published on each topic of a rig (stats keys are topic ``"stats"``).
TOPIC_TYPES: dict[str, type[Frame | Points | Features | ServoCommands | ServiceStats]] = {
    "input": Frame,
    "points": Points,
    "features": Features,
    "servo_commands": ServoCommands,
    "servo_state": ServoCommands,
    "stats": ServiceStats,
}
#: More publications than any unit test makes; the recorder never drops one below this.
RECORD_LIMIT = 1_000_000
#: Virtual seconds a stage may take to shut down in :meth:`StageRun.stop`.
STOP_LIMIT_S = 60.0


@dataclass(frozen=True, slots=True)
class Publication:
    """One message the stage published: when (virtual monotonic ns), where, and what."""

    t_ns: int
    key: str
    topic: str
    message: Any

    @property
    def t(self) -> float:
        """Virtual time in seconds."""
        return self.t_ns / 1e9


class StageRun:
    """One stage's service body running on a fresh in-memory bus with a fake clock.

    ``body`` is what ``run_service`` would run (e.g. ``control.serve`` or
    ``lambda ctx: serve_features(ctx, processor)``); ``service`` names it (its keys and
    stats), ``robot`` the robot whose command keys it uses, if any. Use as ``async with``:
    entering starts the body and lets it reach its first wait; leaving cancels it (like
    SIGTERM) and closes the bus.
    """

    def __init__(
        self,
        body: Body,
        *,
        service: str,
        rig: str = "test",
        instance: str = "one",
        stats_interval: float = 1.0,
        clock: FakeClock | None = None,
        robot: str | None = None,
    ) -> None:
        self.clock = clock if clock is not None else FakeClock()
        self.network = MemoryNetwork(self.clock)
        self.rig = rig
        self.ctx = ServiceContext(
            self.network.bus(),
            rig,
            service,
            instance=instance,
            stats_interval=stats_interval,
            clock=self.clock,
            robot=robot,
        )
        self._body = body
        self._probe = self.network.bus()
        self._recorder: Subscription | None = None
        self._published: list[Publication] = []
        self.task: asyncio.Task[Any] | None = None

    # --- lifetime ------------------------------------------------------------------------

    async def start(self) -> None:
        """Start the body and let it run until it waits (for input or for time)."""
        if self.task is not None:
            raise RuntimeError("this stage is already running")
        self._recorder = self._probe.subscribe_queued(f"{keys.PREFIX}/{self.rig}/**", RECORD_LIMIT)
        self.task = asyncio.create_task(run_service(self.ctx, self._body))
        await self.clock.settle()

    async def stop(self) -> Any:
        """Cancel the body if it still runs (as on SIGTERM); return its result if it ended.

        What the body does on its way out on the clock (a control interface returning the face
        to neutral) runs in virtual time, up to ``STOP_LIMIT_S``. An exception the body raised
        is raised here.
        """
        result = None
        if self.task is not None:
            if not self.task.done():
                self.task.cancel()
                with contextlib.suppress(IdleTimeout):
                    await self.clock.run_until(self.task.done, STOP_LIMIT_S)
            with contextlib.suppress(asyncio.CancelledError):
                result = await self.task
        self._drain()
        await self.ctx.bus.close()
        await self._probe.close()
        return result

    async def __aenter__(self) -> Self:
        await self.start()
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        if exc is None:
            await self.stop()
        else:  # the test failed already: clean up without hiding its error
            with contextlib.suppress(Exception):
                await self.stop()

    # --- input and time ------------------------------------------------------------------

    async def send(
        self,
        topic: keys.Stage,
        message: msgspec.Struct | bytes,
        *,
        robot: str | None = None,
        in_process: bool = False,
    ) -> None:
        """Publish ``message`` (encoded, or raw bytes as given) on the rig's ``topic`` now
        (``robot``'s key of it, for the per-robot stages); with ``in_process``, as the object
        itself, as a stage of the same process publishes (``Bus.publish_message``).

        The stage then runs until it waits again; the test's own messages are not recorded.
        """
        self._drain()
        key = keys.stage_key(self.rig, topic, robot)
        if in_process:
            self._probe.publish_message(key, message, codec.encode)
        else:
            payload = message if isinstance(message, bytes) else codec.encode(message)
            self._probe.publish(key, payload)
        if self._recorder is not None:
            self._recorder.receive_nowait()  # our own message, delivered synchronously
        await self.clock.settle()

    async def advance(self, seconds: float) -> None:
        """Move virtual time forward, letting the stage do everything due on the way."""
        await self.clock.advance(seconds)

    async def run_until(self, condition: Callable[[], bool], timeout: float) -> None:
        """Move time from one wake-up to the next until ``condition()`` holds (see FakeClock)."""
        await self.clock.run_until(condition, timeout)

    async def finish(self, timeout: float) -> Any:
        """Run until the body returns on its own (within ``timeout`` virtual s); its result."""
        if self.task is None:
            raise RuntimeError("the stage was not started")
        task = self.task
        await self.clock.run_until(task.done, timeout)
        return task.result()

    @property
    def now(self) -> float:
        """Virtual time in seconds since the run started."""
        return self.clock.seconds

    # --- what came out -------------------------------------------------------------------

    @property
    def published(self) -> list[Publication]:
        """Everything the stage published on its rig so far, in order."""
        self._drain()
        return list(self._published)

    def on(self, topic: str) -> list[Publication]:
        """Publications on ``topic`` (a stage name, or ``"stats"``)."""
        return [p for p in self.published if p.topic == topic]

    def messages(self, topic: str) -> list[Any]:
        """Decoded messages published on ``topic``."""
        return [p.message for p in self.on(topic)]

    def alive(self) -> bool:
        """Whether the stage's liveliness token is announced."""
        return bool(self.network.tokens)

    def _drain(self) -> None:
        if self._recorder is None:
            return
        offset = wall_offset_ns(self.clock)  # the bus stamps receipt in wall time
        while (sample := self._recorder.receive_nowait()) is not None:
            topic = _topic(self.rig, sample.key)
            kind = TOPIC_TYPES.get(topic)
            message: Any = sample.payload
            if kind is not None:
                try:
                    message = codec.decode(sample.payload, kind)  # type: ignore[type-var]
                except ValueError as exc:
                    raise AssertionError(f"undecodable {topic} published: {exc}") from None
            self._published.append(
                Publication(sample.t_received_ns - offset, sample.key, topic, message)
            )


def _topic(rig: str, key: str) -> str:
    """``input`` … ``servo_state`` for stage keys, ``stats`` for stats keys, else the key."""
    prefix = f"{keys.PREFIX}/{rig}/"
    rest = key[len(prefix) :] if key.startswith(prefix) else key
    return rest.split("/", 1)[0]
