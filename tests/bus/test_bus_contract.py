"""One contract, two transports: the in-memory bus and Zenoh through a real loopback router."""

from __future__ import annotations

import asyncio
import time
from collections.abc import AsyncIterator, Callable

import pytest

from facesynth.runtime.bus.base import Bus, SubscriptionClosed
from facesynth.runtime.bus.memory import MemoryNetwork
from facesynth.runtime.bus.zenoh_bus import ZenohBus, ZenohOptions

DELIVERY_TIMEOUT = 5.0
Factory = Callable[[], Bus]


@pytest.fixture(params=["memory", "zenoh-peer", "zenoh-client"])
async def make_bus(request: pytest.FixtureRequest) -> AsyncIterator[Factory]:
    """A factory of buses that all see each other, for each transport."""
    buses: list[Bus] = []
    if request.param == "memory":
        network = MemoryNetwork()

        def factory() -> Bus:
            buses.append(network.bus())
            return buses[-1]
    else:
        locator = request.getfixturevalue("zenoh_router")
        mode = request.param.split("-")[1]

        def factory() -> Bus:
            buses.append(ZenohBus.open(ZenohOptions(mode=mode, connect=[locator])))
            return buses[-1]

    yield factory
    for bus in buses:
        await bus.close()


async def settle(bus: Bus) -> None:
    """Give a real transport time to propagate declarations (no-op cost for memory)."""
    if isinstance(bus, ZenohBus):
        await asyncio.sleep(0.3)


async def test_published_payload_arrives_on_other_bus(make_bus: Factory, key_prefix: str) -> None:
    sender, receiver = make_bus(), make_bus()
    subscription = receiver.subscribe_queued(f"{key_prefix}/a", 8)
    await settle(receiver)
    sender.publish(f"{key_prefix}/a", b"\x00payload\xff")
    sample = await asyncio.wait_for(subscription.receive(), DELIVERY_TIMEOUT)
    assert sample.key == f"{key_prefix}/a"
    assert sample.payload == b"\x00payload\xff"
    assert sample.t_received_ns > 0


async def test_queued_keeps_order(make_bus: Factory, key_prefix: str) -> None:
    sender, receiver = make_bus(), make_bus()
    subscription = receiver.subscribe_queued(f"{key_prefix}/q", 100)
    await settle(receiver)
    for i in range(50):
        sender.publish(f"{key_prefix}/q", str(i).encode())
    got = [
        int((await asyncio.wait_for(subscription.receive(), DELIVERY_TIMEOUT)).payload)
        for _ in range(50)
    ]
    assert got == list(range(50))
    assert subscription.dropped == 0


async def test_queued_drops_oldest_when_full(make_bus: Factory, key_prefix: str) -> None:
    sender, receiver = make_bus(), make_bus()
    subscription = receiver.subscribe_queued(f"{key_prefix}/full", 3)
    await settle(receiver)
    for i in range(10):
        sender.publish(f"{key_prefix}/full", str(i).encode())
    await _wait_received(subscription, 10)
    got = [int(s.payload) for s in iter(subscription.receive_nowait, None)]
    assert got == [7, 8, 9]
    assert subscription.dropped == 7


async def test_a_polled_mailbox_stores_screened_samples_without_waking_its_reader(
    make_bus: Factory, key_prefix: str
) -> None:
    sender, receiver = make_bus(), make_bus()
    subscription = receiver.subscribe_queued(f"{key_prefix}/polled", 3)

    def screen(payload: bytes) -> int:
        if payload == b"bad":
            raise ValueError("bad")
        return int(payload)

    subscription.guard(1024, screen)
    subscription.poll_only()
    await settle(receiver)
    for payload in (b"0", b"bad", b"1", b"2", b"3", b"4"):
        sender.publish(f"{key_prefix}/polled", payload)
    await _wait_received(subscription, 5)
    assert [s.message for s in iter(subscription.receive_nowait, None)] == [2, 3, 4]
    assert subscription.dropped == 2 and subscription.refused == 1
    with pytest.raises(RuntimeError, match="receive_nowait"):
        await subscription.receive()
    sender.publish(f"{key_prefix}/polled", b"5")
    await _wait_received(subscription, 6)
    subscription.close()
    assert subscription.receive_nowait() is None


async def test_latest_keeps_only_newest(make_bus: Factory, key_prefix: str) -> None:
    sender, receiver = make_bus(), make_bus()
    subscription = receiver.subscribe_latest(f"{key_prefix}/latest")
    await settle(receiver)
    for i in range(5):
        sender.publish(f"{key_prefix}/latest", str(i).encode())
    await _wait_received(subscription, 5)
    sample = await asyncio.wait_for(subscription.receive(), DELIVERY_TIMEOUT)
    assert sample.payload == b"4"
    assert subscription.pending() == 0
    assert subscription.dropped == 4


async def test_wildcard_subscription_and_no_cross_talk(make_bus: Factory, key_prefix: str) -> None:
    sender, receiver = make_bus(), make_bus()
    everything = receiver.subscribe_queued(f"{key_prefix}/stats/**", 8)
    only_a = receiver.subscribe_queued(f"{key_prefix}/stats/a/1", 8)
    await settle(receiver)
    sender.publish(f"{key_prefix}/stats/a/1", b"a")
    sender.publish(f"{key_prefix}/stats/b/2", b"b")
    sender.publish(f"{key_prefix}/other", b"x")
    keys = sorted(
        [(await asyncio.wait_for(everything.receive(), DELIVERY_TIMEOUT)).key for _ in range(2)]
    )
    assert keys == [f"{key_prefix}/stats/a/1", f"{key_prefix}/stats/b/2"]
    assert (await asyncio.wait_for(only_a.receive(), DELIVERY_TIMEOUT)).payload == b"a"
    await asyncio.sleep(0.2)
    assert everything.pending() == 0 and only_a.pending() == 0


async def test_same_bus_receives_its_own_publications(make_bus: Factory, key_prefix: str) -> None:
    bus = make_bus()
    subscription = bus.subscribe_queued(f"{key_prefix}/self", 4)
    await settle(bus)
    bus.publish(f"{key_prefix}/self", b"me")
    assert (await asyncio.wait_for(subscription.receive(), DELIVERY_TIMEOUT)).payload == b"me"


async def test_every_subscription_of_one_bus_gets_every_sample(
    make_bus: Factory, key_prefix: str
) -> None:
    # Several stages in one process subscribe to the same key (many robots' translators).
    sender, receiver = make_bus(), make_bus()
    first = receiver.subscribe_queued(f"{key_prefix}/shared", 8)
    second = receiver.subscribe_queued(f"{key_prefix}/shared", 8)
    wide = receiver.subscribe_queued(f"{key_prefix}/**", 8)
    await settle(receiver)
    sender.publish(f"{key_prefix}/shared", b"remote")
    receiver.publish(f"{key_prefix}/shared", b"local")
    for subscription in (first, second, wide):
        got = sorted(
            [
                (await asyncio.wait_for(subscription.receive(), DELIVERY_TIMEOUT)).payload
                for _ in range(2)
            ]
        )
        assert got == [b"local", b"remote"]
    await asyncio.sleep(0.2)  # and nothing twice
    assert first.pending() == second.pending() == wide.pending() == 0


async def test_closing_one_of_two_subscriptions_on_a_key_leaves_the_other(
    make_bus: Factory, key_prefix: str
) -> None:
    sender, receiver = make_bus(), make_bus()
    kept = receiver.subscribe_queued(f"{key_prefix}/k", 8)
    closed = receiver.subscribe_queued(f"{key_prefix}/k", 8)
    await settle(receiver)
    closed.close()
    for bus in (sender, receiver):
        bus.publish(f"{key_prefix}/k", b"after")
        assert (await asyncio.wait_for(kept.receive(), DELIVERY_TIMEOUT)).payload == b"after"
    assert closed.pending() == 0 and closed.received == 0
    kept.close()
    again = receiver.subscribe_queued(f"{key_prefix}/k", 8)  # a key can be subscribed anew
    await settle(receiver)
    sender.publish(f"{key_prefix}/k", b"anew")
    assert (await asyncio.wait_for(again.receive(), DELIVERY_TIMEOUT)).payload == b"anew"


async def test_close_wakes_waiting_receiver(make_bus: Factory, key_prefix: str) -> None:
    bus = make_bus()
    subscription = bus.subscribe_queued(f"{key_prefix}/closing", 4)
    waiter = asyncio.create_task(subscription.receive())
    await asyncio.sleep(0.05)
    subscription.close()
    with pytest.raises(SubscriptionClosed):
        await asyncio.wait_for(waiter, DELIVERY_TIMEOUT)
    assert [s async for s in subscription] == []


async def test_closed_subscription_receives_nothing_more(
    make_bus: Factory, key_prefix: str
) -> None:
    sender, receiver = make_bus(), make_bus()
    subscription = receiver.subscribe_queued(f"{key_prefix}/gone", 4)
    await settle(receiver)
    subscription.close()
    sender.publish(f"{key_prefix}/gone", b"late")
    await asyncio.sleep(0.2)
    assert subscription.pending() == 0 and subscription.received == 0


async def test_liveliness_appears_and_disappears(make_bus: Factory, key_prefix: str) -> None:
    announcer, observer = make_bus(), make_bus()
    token = announcer.declare_token(f"{key_prefix}/health/points/one")
    other = announcer.declare_token(f"{key_prefix}/elsewhere/x")
    await settle(announcer)
    assert await observer.alive(f"{key_prefix}/health/**") == [f"{key_prefix}/health/points/one"]
    token.close()
    await settle(announcer)
    assert await observer.alive(f"{key_prefix}/health/**") == []
    other.close()


async def test_bus_close_withdraws_tokens(make_bus: Factory, key_prefix: str) -> None:
    announcer, observer = make_bus(), make_bus()
    announcer.declare_token(f"{key_prefix}/health/x/1")
    await settle(announcer)
    assert await observer.alive(f"{key_prefix}/health/**") == [f"{key_prefix}/health/x/1"]
    await announcer.close()
    await settle(observer)
    assert await observer.alive(f"{key_prefix}/health/**") == []


async def test_a_subscriber_that_never_reads_does_not_slow_the_publisher(
    make_bus: Factory, key_prefix: str
) -> None:
    sender, receiver = make_bus(), make_bus()
    subscription = receiver.subscribe_queued(f"{key_prefix}/unread", 4)
    await settle(receiver)
    payload = bytes(2_000)
    slowest = 0.0
    for _ in range(300):
        before = time.perf_counter()
        sender.publish(f"{key_prefix}/unread", payload)
        slowest = max(slowest, time.perf_counter() - before)
        await asyncio.sleep(0.001)  # like a service between two messages
    await asyncio.sleep(0.5 if isinstance(sender, ZenohBus) else 0)
    assert slowest < 0.25, f"publish took {slowest:.3f} s"
    # The mailbox stays bounded: what did not fit was dropped (oldest first) and counted.
    assert subscription.received > 4 and subscription.pending() == 4
    assert subscription.dropped == subscription.received - 4


async def test_async_with_closes_the_bus(make_bus: Factory, key_prefix: str) -> None:
    observer = make_bus()
    async with make_bus() as bus:
        subscription = bus.subscribe_queued(f"{key_prefix}/ctx", 4)
        bus.declare_token(f"{key_prefix}/health/ctx/1")
        await settle(bus)
        assert await observer.alive(f"{key_prefix}/health/**") == [f"{key_prefix}/health/ctx/1"]
    assert subscription.closed
    await settle(observer)
    assert await observer.alive(f"{key_prefix}/health/**") == []


async def test_subscription_needs_room(make_bus: Factory, key_prefix: str) -> None:
    with pytest.raises(ValueError, match="at least one"):
        make_bus().subscribe_queued(f"{key_prefix}/x", 0)


async def test_invalid_key_is_refused(make_bus: Factory) -> None:
    bus = make_bus()
    with pytest.raises(Exception, match=r"(?i)key"):
        bus.declare_token("bad//key")


async def _wait_received(subscription: object, count: int) -> None:
    for _ in range(int(DELIVERY_TIMEOUT / 0.01)):
        if subscription.received >= count:
            return
        await asyncio.sleep(0.01)
    raise AssertionError(f"only {subscription.received} of {count} samples arrived")


async def test_oversized_payloads_are_refused_on_arrival_and_reported_in_batches(
    make_bus: Factory, key_prefix: str
) -> None:
    sender, receiver = make_bus(), make_bus()
    subscription = receiver.subscribe_queued(f"{key_prefix}/big", 64)
    reports: list[tuple[int, str]] = []
    subscription.guard(1000, on_refused=lambda count, reason: reports.append((count, reason)))
    await settle(receiver)
    for i in range(20):
        sender.publish(f"{key_prefix}/big", b"x" * (1001 + i) if i % 2 else b"ok")
    sender.publish(f"{key_prefix}/big", b"x" * 1000)  # exactly the limit passes
    got = [
        (await asyncio.wait_for(subscription.receive(), DELIVERY_TIMEOUT)).payload
        for _ in range(11)
    ]
    assert got == [b"ok"] * 10 + [b"x" * 1000]
    await _wait_reported(reports, 10)
    assert subscription.refused == 10 and subscription.received == 11
    assert reports[-1][1] == "1020 bytes, over the limit of 1000"
    assert len(reports) <= 10  # batched: at most one report pending at a time


async def test_a_screen_keeps_refused_payloads_out_of_the_mailbox(
    make_bus: Factory, key_prefix: str
) -> None:
    def screen(payload: bytes) -> int:
        if not payload.isdigit():
            raise ValueError(f"{payload!r} is not a number")
        return int(payload)

    sender, receiver = make_bus(), make_bus()
    latest = receiver.subscribe_latest(f"{key_prefix}/n")
    reports: list[tuple[int, str]] = []
    latest.guard(100, screen, lambda count, reason: reports.append((count, reason)))
    await settle(receiver)
    sender.publish(f"{key_prefix}/n", b"42")
    for _ in range(200):  # a flood of bad messages after the good one
        sender.publish(f"{key_prefix}/n", b"garbage")
    await _wait_reported(reports, 200)
    sample = await asyncio.wait_for(latest.receive(), DELIVERY_TIMEOUT)
    assert (sample.payload, sample.message) == (b"42", 42)  # the flood displaced nothing
    assert latest.dropped == 0 and latest.refused == 200
    assert reports[-1][1] == "b'garbage' is not a number"


async def _wait_reported(reports: list[tuple[int, str]], count: int) -> None:
    for _ in range(int(DELIVERY_TIMEOUT / 0.01)):
        if sum(n for n, _ in reports) >= count:
            return
        await asyncio.sleep(0.01)
    raise AssertionError(f"only {sum(n for n, _ in reports)} of {count} refusals reported")


async def test_buses_sharing_a_zenoh_session_see_each_others_publications(
    zenoh_router: str, key_prefix: str
) -> None:
    # A session's own publications skip Zenoh (allowed_destination=REMOTE): every bus on the
    # session must still get them, and other sessions must get them through Zenoh.
    owner = ZenohBus.open(ZenohOptions(mode="client", connect=[zenoh_router]))
    guest = ZenohBus(owner.session, owns_session=False)
    remote = ZenohBus.open(ZenohOptions(mode="client", connect=[zenoh_router]))
    try:
        on_owner = owner.subscribe_queued(f"{key_prefix}/s", 8)
        on_remote = remote.subscribe_queued(f"{key_prefix}/s", 8)
        await settle(remote)
        guest.publish(f"{key_prefix}/s", b"from the guest")
        for subscription in (on_owner, on_remote):
            sample = await asyncio.wait_for(subscription.receive(), DELIVERY_TIMEOUT)
            assert sample.payload == b"from the guest"
        await asyncio.sleep(0.2)
        assert on_owner.pending() == 0, "delivered twice"
    finally:
        await guest.close()
        await remote.close()
        await owner.close()
