"""A live view of a rig in Foxglove: its keys served over Foxglove's WebSocket protocol.

The server is the ``foxglove-sdk`` package's own (``foxglove.start_server``), with one SDK
context per bridge. Channels are the same as in a recording (:mod:`.layout`): the frame with
the landmarks over it, features, servo commands and applied positions as plottable JSON, and
every service's stats (rate, latency p50/p99 per stage). Messages that are not valid are
not shown (they have no viewable form). The SDK sends a channel's messages only to clients
subscribed to it, and drops the oldest for a client that falls behind.
"""

from __future__ import annotations

import asyncio
from dataclasses import dataclass

import foxglove

from facesynth.app.recording.layout import (
    ANNOTATIONS,
    IMAGE,
    MESSAGE,
    RAW,
    ChannelSpec,
    Layout,
    json_schema,
    message_type,
)
from facesynth.app.recording.views import annotations_schema, compressed_image_schema
from facesynth.runtime import keys
from facesynth.runtime.bus.base import Subscription
from facesynth.runtime.service import ServiceContext
from facesynth.runtime.tasks import stop_tasks

DEFAULT_ADDRESS = "127.0.0.1:8765"


class LiveViewError(ValueError):
    """A live view that cannot start (bad address, port taken)."""


@dataclass(frozen=True)
class Address:
    """Where the WebSocket server listens."""

    host: str
    port: int

    @classmethod
    def parse(cls, text: str) -> Address:
        """``HOST:PORT``, ``:PORT`` or ``HOST`` (port 8765); port 0 picks a free one."""
        if ":" in text:
            host, _, port = text.rpartition(":")
        else:
            host, port = text, "8765"
        host = host.strip("[]") or "127.0.0.1"
        try:
            number = int(port)
        except ValueError:
            raise LiveViewError(
                f"bad Foxglove address {text!r}: use HOST:PORT, e.g. {DEFAULT_ADDRESS}"
            ) from None
        if not 0 <= number <= 65535:
            raise LiveViewError(f"bad Foxglove port {number}: use 0-65535")
        return cls(host, number)


class FoxgloveBridge:
    """Serves bus samples to Foxglove clients; ``start`` opens the server, ``stop`` closes it."""

    def __init__(
        self,
        address: Address,
        *,
        rig: str | None = None,
        name: str = "facesynth",
        frame_every: int = 1,
    ) -> None:
        if frame_every < 1:
            raise LiveViewError("--frame-every must be at least 1 for the live view")
        self.address = address
        self.rig = rig
        self.name = name
        self.frame_every = frame_every
        self.layout = Layout()
        self.context = foxglove.Context()
        self.server: foxglove.WebSocketServer | None = None
        self._channels: dict[ChannelSpec, foxglove.Channel] = {}
        self._frames = 0
        self.shown = 0

    def advertise(self, rig: str) -> None:
        """Create the rig's stage channels now, before any message (stats channels, named by
        instance, and each robot's commands and state appear with their first message).

        A client sees them as soon as it connects, and never subscribes to a channel in the
        instant it is being created (which the SDK's server can refuse as unknown).
        """
        for stage in keys.STAGES:
            key = keys.stage_key(rig, stage)
            cls = message_type(key)
            self._channel(self.layout.channel(key, MESSAGE, json_schema(cls)))  # type: ignore[arg-type]
        self._channel(
            self.layout.channel(keys.stage_key(rig, "input"), IMAGE, compressed_image_schema())
        )
        self._channel(
            self.layout.channel(keys.stage_key(rig, "points"), ANNOTATIONS, annotations_schema())
        )

    def start(self) -> int:
        """Create the rig's channels (when ``rig`` was given), start the server; return its port."""
        if self.rig is not None:
            self.advertise(self.rig)
        try:
            self.server = foxglove.start_server(
                name=self.name, host=self.address.host, port=self.address.port, context=self.context
            )
        except Exception as exc:  # the SDK raises its own error for a taken port or bad host
            raise LiveViewError(
                f"cannot serve Foxglove on {self.address.host}:{self.address.port}: {exc} - "
                "choose another address with --foxglove HOST:PORT (port 0 picks a free one)"
            ) from None
        return self.server.port

    @property
    def url(self) -> str:
        """The server's ``ws://`` address."""
        port = self.server.port if self.server is not None else self.address.port
        return f"ws://{self.address.host}:{port}"

    def _channel(self, spec: ChannelSpec) -> foxglove.Channel:
        channel = self._channels.get(spec)
        if channel is None:
            assert spec.schema is not None
            schema = foxglove.Schema(
                name=spec.schema.name, encoding=spec.schema.encoding, data=spec.schema.data
            )
            channel = foxglove.Channel(
                spec.topic,
                schema=schema,
                message_encoding=spec.message_encoding,
                context=self.context,
                metadata=spec.metadata(),
            )
            self._channels[spec] = channel
        return channel

    def show(self, key: str, payload: bytes, t_received_ns: int) -> None:
        """Send one bus sample to the clients subscribed to its channels."""
        if key.endswith("/input"):
            self._frames += 1
            if (self._frames - 1) % self.frame_every:
                return
        for entry in self.layout.entries(key, payload, t_received_ns, 0):
            if entry.channel.role == RAW:
                continue
            self._channel(entry.channel).log(entry.data, log_time=entry.log_time)
        self.shown += 1

    async def serve(self, ctx: ServiceContext) -> None:
        """Show every data and stats key of ``ctx``'s rig (each robot's too) until cancelled."""
        subscriptions: list[Subscription] = [
            ctx.subscribe(stage, 16, every_robot=True) for stage in keys.STAGES
        ]
        stats = ctx.bus.subscribe_queued(keys.stats_pattern(ctx.rig), 64)
        ctx.subscriptions.append(stats)
        subscriptions.append(stats)
        ctx.ready()
        ctx.log.debug("Foxglove live view of rig %s on %s", ctx.rig, self.url)  # said once, by
        # the command that started it (inspect, run --foxglove): not again here

        async def pump(subscription: Subscription) -> None:
            async for sample in subscription:
                ctx.stats.received += 1
                self.show(sample.key, sample.payload, sample.t_received_ns)

        tasks = [asyncio.create_task(pump(s)) for s in subscriptions]
        try:
            await asyncio.gather(*tasks)
        finally:
            await stop_tasks(tasks)

    def stop(self) -> None:
        """Close the channels and the server."""
        for channel in self._channels.values():
            channel.close()
        self._channels.clear()
        if self.server is not None:
            self.server.stop()
            self.server = None
