"""Fan-out to the page's clients: one latest-only mailbox per client and channel.

The driver offers each message once (``face``, ``frame``, ``points``, ``stats``); every client
has one slot per channel holding the newest message not yet sent. A client's own writer task
takes what is there and sends it; while it waits on a slow browser, newer messages replace older
ones in its slots (counted as dropped). Offering never waits for a client, so a slow or stuck
browser costs the chain nothing but a dictionary store per client and message.
"""

from __future__ import annotations

import asyncio

Outgoing = str | bytes
#: Channels, in the order a client's writer sends what is pending.
CHANNELS = ("pong", "face", "points", "frame", "stats")


class Mailbox:
    """The newest unsent message of each channel for one client."""

    def __init__(self, frames: bool = True) -> None:
        self.frames = frames
        self._slots: dict[str, Outgoing] = {}
        self._ready = asyncio.Event()
        self.offered = 0
        self.dropped = 0
        self.sent = 0

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
        return len(self._slots)

    async def take(self) -> list[Outgoing]:
        """Wait for at least one message, then take every pending one (in channel order)."""
        await self._ready.wait()
        self._ready.clear()
        taken = [self._slots.pop(c) for c in CHANNELS if c in self._slots]
        self.sent += len(taken)
        return taken


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
