"""One contract, two transports: the in-memory bus and Zenoh through a real loopback router.

Messages are published as bytes (``Bus.publish``) or as objects (``Bus.publish_message``).
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import AsyncIterator, Callable

import pytest

from facesynth.runtime import codec
from facesynth.runtime.bus.base import Bus, Subscription, SubscriptionClosed
from facesynth.runtime.bus.memory import MemoryNetwork
from facesynth.runtime.bus.zenoh_bus import ZenohBus, ZenohOptions
from facesynth.runtime.bus.zenoh_outlet import MATCH_GRACE_S
from facesynth.schemas.messages import ServoCommands

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
    assert await _alive_settles(observer, f"{key_prefix}/health/**", 1) == [
        f"{key_prefix}/health/points/one"
    ]
    token.close()
    assert await _alive_settles(observer, f"{key_prefix}/health/**", 0) == []
    other.close()


async def test_bus_close_withdraws_tokens(make_bus: Factory, key_prefix: str) -> None:
    announcer, observer = make_bus(), make_bus()
    announcer.declare_token(f"{key_prefix}/health/x/1")
    assert await _alive_settles(observer, f"{key_prefix}/health/**", 1) == [
        f"{key_prefix}/health/x/1"
    ]
    await announcer.close()
    assert await _alive_settles(observer, f"{key_prefix}/health/**", 0) == []


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
        assert await _alive_settles(observer, f"{key_prefix}/health/**", 1) == [
            f"{key_prefix}/health/ctx/1"
        ]
    assert subscription.closed
    assert await _alive_settles(observer, f"{key_prefix}/health/**", 0) == []


async def test_subscription_needs_room(make_bus: Factory, key_prefix: str) -> None:
    with pytest.raises(ValueError, match="at least one"):
        make_bus().subscribe_queued(f"{key_prefix}/x", 0)


async def test_invalid_key_is_refused(make_bus: Factory) -> None:
    bus = make_bus()
    with pytest.raises(Exception, match=r"(?i)key"):
        bus.declare_token("bad//key")


async def _alive_settles(observer: Bus, key_expr: str, count: int) -> list[str]:
    """What ``observer`` sees alive under ``key_expr`` once it lists ``count`` tokens, or after
    DELIVERY_TIMEOUT: a real transport propagates a token (or its withdrawal) in its own time,
    longer on a busy machine (a peer also learns of the other peer through the router)."""
    deadline = time.monotonic() + DELIVERY_TIMEOUT
    while True:
        seen = await observer.alive(key_expr)
        if len(seen) == count or time.monotonic() > deadline:
            return seen
        await asyncio.sleep(0.05)


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


# --- Messages published as objects (Bus.publish_message) ------------------------------------


class CountingEncoder:
    """``codec.encode``, counting its calls."""

    def __init__(self) -> None:
        self.calls = 0

    def __call__(self, message: ServoCommands) -> bytes:
        self.calls += 1
        return codec.encode(message)


def _command(seq: int, jaw: float = 1500.0) -> ServoCommands:
    return ServoCommands(
        seq=seq, t_capture_ns=seq, t_media_ns=seq, face=True, profile="p", positions={"jaw": jaw}
    )


def _takes_commands(subscription: Subscription, refused: list[tuple[int, str]] | None = None):
    """Guard ``subscription`` as a stage does: bytes decoded, in-process objects checked."""

    def take(message: object) -> ServoCommands:
        checked = codec.check(message, ServoCommands)
        if checked.positions.get("jaw") == 0.0:
            raise ValueError("a jaw at 0")
        return checked

    subscription.guard(
        10_000,
        lambda payload: take(codec.decode(payload, ServoCommands)),
        (lambda count, reason: refused.append((count, reason))) if refused is not None else None,
        take,
    )
    return subscription


async def settle_outlet(bus: Bus, key: str) -> None:
    """Declare ``key``'s publisher and let a Zenoh bus learn who listens to it: a new publisher
    hands Zenoh every message for its first ``MATCH_GRACE_S``."""
    if isinstance(bus, ZenohBus):
        bus.publish_message(key, _command(0), codec.encode)
        await asyncio.sleep(MATCH_GRACE_S + 0.1)


async def test_a_message_reaches_mailboxes_of_its_own_process_as_the_object_itself(
    make_bus: Factory, key_prefix: str
) -> None:
    bus = make_bus()
    key = f"{key_prefix}/obj"
    first = _takes_commands(bus.subscribe_queued(key, 8))
    second = _takes_commands(bus.subscribe_latest(key))
    await settle(bus)
    await settle_outlet(bus, key)
    for subscription in (first, second):
        while subscription.receive_nowait() is not None:
            pass
    encoder = CountingEncoder()
    message = _command(1)
    bus.publish_message(key, message, encoder)
    for subscription in (first, second):
        sample = await asyncio.wait_for(subscription.receive(), DELIVERY_TIMEOUT)
        assert sample.message is message and sample.parcel is not None
    assert encoder.calls == 0, "encoded with no reader of bytes in this or another process"
    # Bytes are still there for whoever asks, encoded once for every reader.
    assert codec.decode(sample.payload, ServoCommands) == message
    assert sample.payload is sample.payload and encoder.calls == 1
    await asyncio.sleep(0.2)  # and nothing twice (Zenoh does not bring it back)
    assert first.pending() == second.pending() == 0


async def test_mailboxes_reading_bytes_get_the_message_encoded_once(
    make_bus: Factory, key_prefix: str
) -> None:
    sender, receiver = make_bus(), make_bus()
    key = f"{key_prefix}/bytes"
    local_bytes = [sender.subscribe_queued(key, 8) for _ in range(2)]
    local_objects = _takes_commands(sender.subscribe_queued(key, 8))
    remote_bytes = [receiver.subscribe_queued(key, 8) for _ in range(2)]
    remote_objects = _takes_commands(receiver.subscribe_queued(key, 8))
    await settle(receiver)
    encoder = CountingEncoder()
    message = _command(7, jaw=1234.5)
    sender.publish_message(key, message, encoder)
    for subscription in [*local_bytes, *remote_bytes]:
        sample = await asyncio.wait_for(subscription.receive(), DELIVERY_TIMEOUT)
        assert codec.decode(sample.payload, ServoCommands) == message
    assert (await asyncio.wait_for(local_objects.receive(), DELIVERY_TIMEOUT)).message is message
    remote = await asyncio.wait_for(remote_objects.receive(), DELIVERY_TIMEOUT)
    assert remote.message == message
    assert encoder.calls == 1, "one encoding per publication, however many read bytes"


async def test_zenoh_gets_the_bytes_only_while_a_subscriber_elsewhere_matches(
    zenoh_router: str, key_prefix: str
) -> None:
    # Encoded (and put) once per publication while another session subscribes, never before
    # or after: the publisher's matching status follows the remote subscriber.
    key = f"{key_prefix}/match"
    sender = ZenohBus.open(ZenohOptions(mode="client", connect=[zenoh_router]))
    observer = ZenohBus.open(ZenohOptions(mode="client", connect=[zenoh_router]))
    try:
        local = _takes_commands(sender.subscribe_queued(key, 64))
        elsewhere = observer.subscribe_queued(f"{key_prefix}/other", 8)  # no match
        await settle_outlet(sender, key)
        encoder = CountingEncoder()
        for seq in range(1, 6):
            sender.publish_message(key, _command(seq), encoder)
        assert encoder.calls == 0
        remote = observer.subscribe_queued(f"{key_prefix}/*", 64)
        await _until(lambda: sender._outlets[key].matching)
        for seq in range(6, 11):
            sender.publish_message(key, _command(seq), encoder)
        assert encoder.calls == 5
        got = [
            codec.decode(
                (await asyncio.wait_for(remote.receive(), DELIVERY_TIMEOUT)).payload, ServoCommands
            ).seq
            for _ in range(5)
        ]
        assert got == [6, 7, 8, 9, 10]
        remote.close()
        await _until(lambda: not sender._outlets[key].matching)
        sender.publish_message(key, _command(11), encoder)
        assert encoder.calls == 5
        seqs = [s.message.seq for s in iter(local.receive_nowait, None)]
        assert seqs == list(range(0, 12)), "the local mailbox got every message, once"
        assert elsewhere.pending() == 0
    finally:
        await observer.close()
        await sender.close()


async def test_objects_refused_by_the_mailbox_are_counted_and_displace_nothing(
    make_bus: Factory, key_prefix: str
) -> None:
    bus = make_bus()
    key = f"{key_prefix}/refuse"
    refused: list[tuple[int, str]] = []
    latest = _takes_commands(bus.subscribe_latest(key), refused)
    await settle(bus)
    bus.publish_message(key, _command(1), codec.encode)
    bus.publish_message(key, _command(2, jaw=0.0), codec.encode)  # refused by the check
    bus.publish_message(key, _command(3, jaw=float("nan")), codec.encode)  # refused: not finite
    bus.publish_message(key, "not a message", codec.encode)  # refused: not a ServoCommands
    await _wait_reported(refused, 3)
    sample = await asyncio.wait_for(latest.receive(), DELIVERY_TIMEOUT)
    assert sample.message.seq == 1 and latest.refused == 3 and latest.dropped == 0
    assert "not a valid ServoCommands message: a str object" in refused[-1][1]
    for seq in range(4, 9):  # latest keeps the newest object, counting the ones it dropped
        bus.publish_message(key, _command(seq), codec.encode)
    await _wait_received(latest, 6)
    assert (await asyncio.wait_for(latest.receive(), DELIVERY_TIMEOUT)).message.seq == 8
    assert latest.dropped == 4


async def _until(condition: Callable[[], bool]) -> None:
    for _ in range(int(DELIVERY_TIMEOUT / 0.01)):
        if condition():
            return
        await asyncio.sleep(0.01)
    raise AssertionError("the condition never held")
