"""A read-only view of one rig's data on the bus, for observers inside a service.

A servo driver only gets positions. Some outputs also show where they came from: the live face
page shows the performer's frame, the tracked landmarks and every stage's latency. Such a
driver is handed a :class:`RigView` by the control service (``ServoDriver.observe``) instead of
the bus itself: it can subscribe to the rig's stages and stats, but cannot publish, and it never
spells a key (the layout stays in :mod:`facesynth.runtime.keys`).
"""

from __future__ import annotations

from facesynth.runtime import keys
from facesynth.runtime.bus.base import Bus, Subscription


class RigView:
    """Subscriptions to one rig's stage keys and stats, nothing else."""

    def __init__(self, bus: Bus, rig: str) -> None:
        self._bus = bus
        self.rig = keys.check_name(rig)

    def latest(self, stage: keys.Stage) -> Subscription:
        """The newest message of a stage only (older ones are dropped while the reader is busy)."""
        return self._bus.subscribe_latest(keys.stage_key(self.rig, stage))

    def stats(self, maxsize: int = 64) -> Subscription:
        """Every service's periodic :class:`~schemas.messages.ServiceStats` on this rig."""
        return self._bus.subscribe_queued(keys.stats_pattern(self.rig), maxsize)
