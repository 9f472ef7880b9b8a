"""The ``record`` service: every key of a rig (or the chosen ones) into a session file.

``servo_commands`` and ``servo_state`` are recorded on the rig's own key and on each robot's
(``…/servo_commands/<robot>``), each on its own channel.

One queued subscription per key, so nothing is dropped while the file is written (drops, if
the disk cannot keep up, are counted in the service's stats); frames can be left out or
thinned (every Nth). A timer cuts the chunk in progress every ``chunk_seconds`` so that a kill
loses at most that much.
"""

from __future__ import annotations

import asyncio
import collections
import time
from dataclasses import dataclass

from facesynth.app.recording import RECORDABLE
from facesynth.app.recording.layout import LAYOUT_VERSION, Layout
from facesynth.app.recording.writer import SessionWriter, WriterThread
from facesynth.runtime import keys
from facesynth.runtime.bus.base import Subscription
from facesynth.runtime.service import ServiceContext
from facesynth.runtime.tasks import cancel_and_wait


class RecordOptionError(ValueError):
    """Recording options that cannot be used."""


def parse_keys(text: str | None) -> list[str]:
    """The ``--keys`` list (comma-separated), checked; all of :data:`RECORDABLE` when empty."""
    if not text:
        return list(RECORDABLE)
    chosen = [part.strip() for part in text.split(",") if part.strip()]
    unknown = [name for name in chosen if name not in RECORDABLE]
    if unknown or not chosen:
        raise RecordOptionError(
            f"unknown key {', '.join(map(repr, unknown)) or repr(text)} for --keys; "
            f"choose from {', '.join(RECORDABLE)}"
        )
    return list(dict.fromkeys(chosen))


@dataclass
class RecordOptions:
    """What to record and how."""

    keys: list[str]
    frame_every: int = 1
    queue: int = 1024
    frame_queue: int = 128
    duration: float | None = None

    def __post_init__(self) -> None:
        if self.frame_every < 0:
            raise RecordOptionError("--frame-every must be >= 0 (0 = no frames)")
        if self.duration is not None and not self.duration > 0:
            raise RecordOptionError("--duration must be positive")

    def metadata(self, rig: str) -> dict[str, str]:
        """The session's metadata record: the rig, what is recorded, when, in which layout."""
        return {
            "rig": rig,
            "keys": ",".join(self.keys),
            "frame_every": str(self.frame_every),
            "started_ns": str(time.time_ns()),
            "layout": LAYOUT_VERSION,
        }


class Recorder:
    """Writes what arrives on a rig's keys, through a :class:`Layout`, into a session file."""

    def __init__(
        self, writer: SessionWriter, options: RecordOptions, layout: Layout | None = None
    ) -> None:
        self.writer = writer
        self.options = options
        self.layout = layout or Layout()
        #: Bus messages recorded, by key; frames left out by thinning are in ``thinned``.
        self.recorded: collections.Counter[str] = collections.Counter()
        self.thinned = 0
        self._seen: collections.Counter[str] = collections.Counter()
        #: Set once the subscriptions exist (what is published from then on is recorded).
        self.listening = asyncio.Event()
        self._sink: WriterThread | None = None

    def take(self, key: str, payload: bytes, t_received_ns: int) -> None:
        """Record one sample (frames are thinned to every ``frame_every``th)."""
        index = self._seen[key]
        self._seen[key] += 1
        if (
            key.endswith("/input")
            and self.options.frame_every > 1
            and index % self.options.frame_every
        ):
            self.thinned += 1
            return
        sink = self._sink or self.writer
        for entry in self.layout.entries(key, payload, t_received_ns, index):
            sink.write(entry)
        self.recorded[key] += 1

    @property
    def refused(self) -> int:
        """Entries the writer thread refused because the disk could not keep up."""
        return self._sink.refused if self._sink is not None else 0

    def _subscriptions(self, ctx: ServiceContext) -> list[Subscription]:
        subscriptions = []
        for name in self.options.keys:
            if name == "stats":
                subscription = ctx.bus.subscribe_queued(
                    keys.stats_pattern(ctx.rig), self.options.queue
                )
                ctx.subscriptions.append(subscription)
            elif name == "input":
                if self.options.frame_every == 0:
                    continue
                subscription = ctx.subscribe("input", self.options.frame_queue)
            else:
                # every robot's commands and state too (…/servo_commands/<robot>)
                subscription = ctx.subscribe(name, self.options.queue, every_robot=True)  # type: ignore[arg-type]
            subscriptions.append(subscription)
        return subscriptions

    async def _drain(self, ctx: ServiceContext, subscription: Subscription) -> None:
        own_stats = keys.stats_key(ctx.rig, ctx.service, ctx.instance)
        async for sample in subscription:
            if sample.key == own_stats:
                continue
            ctx.stats.received += 1
            self.take(sample.key, sample.payload, sample.t_received_ns)
            ctx.stats.record_published(0)

    async def _cut_chunks(self, sink: WriterThread) -> None:
        period = min(0.1, self.writer.chunk_seconds / 4)
        while True:
            await asyncio.sleep(period)
            sink.tick()  # raises the writer's error (disk full): the recording stops

    async def serve(self, ctx: ServiceContext) -> None:
        """Record until cancelled (or for ``duration`` seconds); the file is then complete."""
        sink = self._sink = WriterThread(self.writer)
        tasks = [asyncio.create_task(self._drain(ctx, s)) for s in self._subscriptions(ctx)]
        cutter = asyncio.create_task(self._cut_chunks(sink))
        tasks.append(cutter)
        ctx.ready()
        self.listening.set()
        ctx.log.info(
            "recording %s of rig %s into %s",
            ", ".join(self.options.keys),
            ctx.rig,
            self.writer.path,
        )
        try:
            if self.options.duration is not None:
                await asyncio.wait([cutter], timeout=self.options.duration)
            else:
                await cutter  # runs until cancelled, or raises the writer's error
        finally:
            try:
                await cancel_and_wait(tasks)  # cancelled meanwhile: raised once all have ended
            finally:
                try:
                    self._take_pending(ctx)
                finally:
                    self._sink = None
                    sink.close()  # writes what is queued, completes the file, raises its error

    def _take_pending(self, ctx: ServiceContext) -> None:
        """Record what already arrived but was not taken yet when recording stopped."""
        own_stats = keys.stats_key(ctx.rig, ctx.service, ctx.instance)
        for subscription in ctx.subscriptions:
            while (sample := subscription.receive_nowait()) is not None:
                if sample.key != own_stats:
                    self.take(sample.key, sample.payload, sample.t_received_ns)
