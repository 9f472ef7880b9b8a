"""One open console page: whether it gave the token, and what the console sends it (its
replies in order, everything else latest-only).

Replies (``welcome``, ``error``, ``saved``…) are kept in order, at most :data:`MAX_REPLIES`
(older ones are dropped for a page that does not read); the servos' state, the stage table,
frames and landmarks keep only their newest message per channel, so a slow page costs the
console a dictionary store per message and never holds it up.
"""

from __future__ import annotations

import asyncio
import collections

#: Replies kept for a page that is slow to read; older ones are dropped.
MAX_REPLIES = 64


class Outbox:
    """One page's outgoing messages (see the module docstring)."""

    def __init__(self) -> None:
        self.frames = True
        self.replies: collections.deque[str] = collections.deque(maxlen=MAX_REPLIES)
        self.slots: dict[str, str | bytes] = {}
        self.ready = asyncio.Event()

    def say(self, text: str, replaces: str | None = None) -> None:
        """Queue a reply (kept in order); it supersedes what channel ``replaces`` holds."""
        if replaces is not None:
            self.slots.pop(replaces, None)
        self.replies.append(text)
        self.ready.set()

    def offer(self, channel: str, message: str | bytes) -> None:
        """The newest message of ``channel`` (frames and points only when the page shows them)."""
        if channel in ("frame", "points") and not self.frames:
            return
        self.slots[channel] = message
        self.ready.set()

    async def take(self) -> list[str | bytes]:
        """Wait for something to send, then take all of it: replies first."""
        await self.ready.wait()
        self.ready.clear()
        items: list[str | bytes] = [*self.replies, *self.slots.values()]
        self.replies.clear()
        self.slots.clear()
        return items


class Page:
    """One open page: its outbox and whether it gave the token."""

    def __init__(self) -> None:
        self.outbox = Outbox()
        self.trusted = False
