"""One open console page: whether it gave the token, and what the console sends it.

Its outbox is the live face page's :class:`~services.control.drivers.virtual.fanout.Mailbox`:
replies (``welcome``, ``error``, ``saved``…) in order and bounded, everything else (the servos'
state, the stage table, frames and landmarks, C's state, calibration progress) latest-only per
channel, in the order it came, so a slow page costs the console a dictionary store per message
and never holds it up.
"""

from __future__ import annotations

from facesynth.services.control.drivers.virtual.fanout import Mailbox


class Page:
    """One open page: its outbox and whether it gave the token."""

    def __init__(self) -> None:
        self.outbox = Mailbox(order=())
        self.trusted = False
