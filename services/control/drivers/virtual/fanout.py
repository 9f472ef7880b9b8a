"""Fan-out to the page's clients: one latest-only mailbox per client and channel.

The driver offers each message once (``face``, ``frame``, ``points``, ``stats``); every client
has one slot per channel holding the newest message not yet sent. A client's own writer task
(:meth:`Mailbox.send_to`, run while in :meth:`Mailbox.sending`) takes what is there and sends
it; while it waits on a slow browser, newer messages replace older ones in its slots (counted as
dropped). Offering never waits for a client, so a slow or stuck browser costs the chain nothing
but a dictionary store per client and message.

A page that talks back (the rig console, :mod:`facesynth.app.console.server`) also gets replies
(``welcome``, ``error``, ``saved``…) through :meth:`Mailbox.say`: kept in order, at most
:data:`MAX_REPLIES` (older ones are dropped for a page that does not read), and sent before
anything else.
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
from collections.abc import AsyncIterator
from typing import Protocol

Outgoing = str | bytes
#: Channels, in the order a client's writer sends what is pending.
CHANNELS = ("pong", "face", "points", "frame", "stats")
#: Replies kept for a page that is slow to read; older ones are dropped.
MAX_REPLIES = 64


class Socket(Protocol):
    """What :meth:`Mailbox.send_to` needs of a WebSocket (aiohttp's ``WebSocketResponse``)."""

    @property
    def closed(self) -> bool: ...

    async def send_str(self, data: str) -> None: ...

    async def send_bytes(self, data: bytes) -> None: ...


class Mailbox:
    """One client's outgoing messages: its replies in order, and the newest unsent message of
    each channel (see the module docstring).

    ``order``: the channels a take sends first, in that order; any other channel follows in
    the order it was first offered since the last take (``()``: all in that order)."""

    def __init__(self, frames: bool = True, order: tuple[str, ...] = CHANNELS) -> None:
        self.frames = frames
        self.order = order
        self._replies: collections.deque[str] = collections.deque(maxlen=MAX_REPLIES)
        self._slots: dict[str, Outgoing] = {}
        self._ready = asyncio.Event()
        self.offered = 0
        self.dropped = 0
        self.sent = 0

    def say(self, text: str, replaces: str | None = None) -> None:
        """Queue a reply (kept in order); it supersedes what channel ``replaces`` holds."""
        if replaces is not None:
            self._slots.pop(replaces, None)
        self._replies.append(text)
        self._ready.set()

    def offer(self, channel: str, message: Outgoing) -> None:
        """Put ``message`` in its channel's slot, replacing (dropping) an unsent one."""
        if channel in ("frame", "points") and not self.frames:
            return
        self.offered += 1
        if channel in self._slots:
            self.dropped += 1
        self._slots[channel] = message
        self._ready.set()

    def pending(self) -> int:
        """Messages waiting to be sent."""
        return len(self._replies) + len(self._slots)

    async def take(self) -> list[Outgoing]:
        """Wait for at least one message, then take every pending one: replies first, then
        the channels (``order`` first)."""
        await self._ready.wait()
        self._ready.clear()
        taken: list[Outgoing] = [*self._replies]
        self._replies.clear()
        taken += [self._slots.pop(c) for c in self.order if c in self._slots]
        taken += self._slots.values()
        self._slots.clear()
        self.sent += len(taken)
        return taken

    async def send_to(self, ws: Socket) -> None:
        """Send the client what this mailbox holds until it leaves; only the task running this
        waits on a slow page."""
        try:
            while not ws.closed:
                for item in await self.take():
                    if isinstance(item, bytes):
                        await ws.send_bytes(item)
                    else:
                        await ws.send_str(item)
        except (ConnectionError, RuntimeError):
            pass

    @contextlib.asynccontextmanager
    async def sending(self, ws: Socket, name: str) -> AsyncIterator[None]:
        """While inside, a task (named ``name``) runs :meth:`send_to`; leaving stops it."""
        writer = asyncio.create_task(self.send_to(ws), name=name)
        try:
            yield
        finally:
            writer.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await writer


class Fanout:
    """Every connected client's mailbox."""

    def __init__(self) -> None:
        self.clients: set[Mailbox] = set()
        self.offered = 0
        self._gone_dropped = 0

    def add(self, frames: bool = True) -> Mailbox:
        """A mailbox for a new client."""
        mailbox = Mailbox(frames)
        self.clients.add(mailbox)
        return mailbox

    def remove(self, mailbox: Mailbox) -> None:
        """Forget a client that left (its drop count is kept in :attr:`dropped`)."""
        if mailbox in self.clients:
            self.clients.discard(mailbox)
            self._gone_dropped += mailbox.dropped

    def offer(self, channel: str, message: Outgoing) -> None:
        """Offer one message to every client; never waits."""
        self.offered += 1
        for mailbox in self.clients:
            mailbox.offer(channel, message)

    def wants_frames(self) -> bool:
        """Whether any client shows the performer's frames."""
        return any(m.frames for m in self.clients)

    @property
    def dropped(self) -> int:
        """Messages replaced before a client could be sent them, over all clients ever."""
        return self._gone_dropped + sum(m.dropped for m in self.clients)
