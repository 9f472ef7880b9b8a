"""The bus seam (publish / subscribe-latest / subscribe-queued / liveliness) and its transports."""

from facesynth.runtime.bus.base import (
    Bus,
    Subscription,
    SubscriptionClosed,
    Token,
)
from facesynth.runtime.bus.memory import MemoryBus, MemoryNetwork
from facesynth.runtime.bus.sample import Parcel, Sample

__all__ = [
    "Bus",
    "MemoryBus",
    "MemoryNetwork",
    "Parcel",
    "Sample",
    "Subscription",
    "SubscriptionClosed",
    "Token",
]
