"""In-memory bus for unit tests: same contract as Zenoh, no network, no threads.

Several :class:`MemoryBus` instances made from one :class:`MemoryNetwork` see each other, like
services on one Zenoh network. Key expressions match with Zenoh's own rules. Publishing delivers
synchronously into the subscribers' mailboxes, so it never waits; samples are stamped with the
network's clock (a :class:`~facesynth.runtime.clock.FakeClock` in tests that control time).
The buses of a network share one process, so a message published as an object
(:meth:`~facesynth.runtime.bus.base.Bus.publish_message`) reaches every mailbox taking objects as
that object, and is encoded only for mailboxes that read bytes.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import zenoh

from facesynth.runtime.bus.base import Bus, Subscription, Token
from facesynth.runtime.bus.sample import Parcel, Sample
from facesynth.runtime.clock import Clock, SystemClock


class MemoryNetwork:
    """Shared routing table of a group of in-memory buses."""

    def __init__(self, clock: Clock | None = None) -> None:
        self.clock: Clock = clock if clock is not None else SystemClock()
        self.subscriptions: list[tuple[zenoh.KeyExpr, Subscription]] = []
        self.tokens: dict[int, str] = {}

    def bus(self) -> MemoryBus:
        """A new bus attached to this network."""
        return MemoryBus(self)


class _MemorySubscription(Subscription):
    def __init__(self, network: MemoryNetwork, key_expr: str, maxsize: int) -> None:
        super().__init__(key_expr, maxsize)
        self._network = network
        self._entry = (zenoh.KeyExpr(key_expr), self)
        network.subscriptions.append(self._entry)

    def _release(self) -> None:
        if self._entry in self._network.subscriptions:
            self._network.subscriptions.remove(self._entry)


class _MemoryToken(Token):
    def __init__(self, network: MemoryNetwork, key: str) -> None:
        self._network = network
        network.tokens[id(self)] = key

    def close(self) -> None:
        self._network.tokens.pop(id(self), None)


class MemoryBus(Bus):
    """A bus whose messages go straight into subscribers' mailboxes on the same loop."""

    def __init__(self, network: MemoryNetwork | None = None) -> None:
        self.network = network if network is not None else MemoryNetwork()
        self._owned: list[Subscription] = []
        self._tokens: list[Token] = []

    def publish(self, key: str, payload: bytes) -> None:
        self._deliver(Sample(key, bytes(payload), self.network.clock.time_ns()))

    def publish_message(self, key: str, message: Any, encode: Callable[[Any], bytes]) -> None:
        self._deliver(Sample(key, Parcel(message, encode), self.network.clock.time_ns()))

    def _deliver(self, sample: Sample) -> None:
        key = sample.key
        concrete = zenoh.KeyExpr(key)
        for key_expr, subscription in list(self.network.subscriptions):
            if key_expr.intersects(concrete):
                subscription.deliver(sample)

    def _subscribe(self, key_expr: str, maxsize: int) -> Subscription:
        subscription = _MemorySubscription(self.network, key_expr, maxsize)
        self._owned.append(subscription)
        return subscription

    def declare_token(self, key: str) -> Token:
        zenoh.KeyExpr(key)  # same validation as Zenoh
        token = _MemoryToken(self.network, key)
        self._tokens.append(token)
        return token

    async def alive(self, key_expr: str, timeout: float = 1.0) -> list[str]:
        pattern = zenoh.KeyExpr(key_expr)
        return sorted(
            k for k in self.network.tokens.values() if pattern.intersects(zenoh.KeyExpr(k))
        )

    async def close(self) -> None:
        for subscription in self._owned:
            subscription.close()
        for token in self._tokens:
            token.close()
        self._owned.clear()
        self._tokens.clear()
