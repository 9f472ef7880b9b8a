"""The Zenoh implementation of the bus seam, and how a session is configured.

Zenoh's Python API has no asyncio support: subscriber callbacks run on Zenoh's own threads. They
only copy the payload and hand it to the event loop with ``call_soon_threadsafe``; they never
block and never call Zenoh. Publications use ``CongestionControl.DROP``, so ``publish`` never
waits for a slow or stopped subscriber (the measurements are in :class:`~.base.Bus`).

**Inside one process, messages skip Zenoh.** Several stages in one process (``facesynth run``,
a robot host serving many robots) share one session. Every subscription of a session on the
same key expression shares one Zenoh subscriber, which only takes samples from *other* sessions
(``allowed_origin=REMOTE``) and hands each to all of them in one event-loop wake-up; and a
publication reaches the session's own matching subscriptions directly (as the in-memory bus
does), while Zenoh carries it to other sessions only (``allowed_destination=REMOTE``). Otherwise
each local message would cross Zenoh's routing and a Python callback thread per subscriber:
measured with 16 robots in one process (``facesynth bench fanout --layout shared``), … .

A message published as an object (:meth:`ZenohBus.publish_message`) reaches the session's own
mailboxes that take objects as that object, and is handed to Zenoh only while a subscriber of
another session matches its key (the publisher's matching status, followed by a matching
listener), encoded once however many match: stages sharing a process pay no msgpack and no
Zenoh ``put`` while nobody elsewhere listens, and recorders, observers and remote stages still
get every message.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import json
import logging
import os
import re
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Final

import zenoh

from facesynth.runtime.bus.base import Bus, Subscription, Token
from facesynth.runtime.bus.link import LinkFigures, RouterLink, short_id
from facesynth.runtime.bus.sample import Parcel, Sample
from facesynth.runtime.bus.zenoh_outlet import Outlet
from facesynth.runtime.bus.zenoh_routes import SessionRoutes, ZenohSubscription
from facesynth.runtime.bus.zenoh_selfcheck import router_holds, watch
from facesynth.runtime.bus.zenoh_token import ZenohToken

#: Where services look for a router when given no --connect (``facesynth router``'s default).
DEFAULT_ROUTER = "tcp/127.0.0.1:7447"
MODES = ("peer", "client", "router")

log = logging.getLogger("facesynth.link")


class ZenohConfigError(ValueError):
    """A Zenoh configuration that cannot be used (bad file, bad endpoint, bad mode)."""


#: Zenoh's setting for the largest message a session reassembles and delivers.
MESSAGE_LIMIT_PATH: Final = "transport/link/rx/max_message_size"
#: Zenoh's setting for the smallest payload it sends through shared memory to a session on the
#: same host, its default, and facesynth's. Zenoh's 3 KiB sends every JPEG frame, Points and
#: Features message through shared memory, and at 30 messages a second that costs more CPU
#: than the copy it saves: measured on loopback (one publisher, a router, one subscriber, 30
#: messages/s, plain Zenoh sessions), 6 kB payloads took 0.15-0.19 ms of CPU per message to
#: receive, 0.23-0.24 to publish and 0.17-0.20 in the router without shared memory, against
#: 0.24-0.26, 0.39-0.48 and 0.31 with it (40 kB alike). In ``facesynth bench chain`` the
#: difference is within the run-to-run spread of a shared 2-core machine. Raw frames (hundreds
#: of kB) still go through shared memory.
SHM_THRESHOLD_PATH: Final = "transport/shared_memory/transport_optimization/message_size_threshold"
ZENOH_SHM_THRESHOLD: Final = 3072
SHM_THRESHOLD: Final = 256 * 1024


@dataclass
class ZenohOptions:
    """The standard Zenoh options of every facesynth command.

    ``config_file`` (or the ``ZENOH_CONFIG`` environment variable) is read first; ``mode``,
    ``connect`` and ``listen`` override it. Multicast scouting stays off unless ``scouting`` is
    true, so services only meet the routers and peers they are told about. Gossip stays on: it
    travels only over links a session already has, and without it two peers connected to the
    same router never exchange data (clients do; measured with eclipse-zenoh 1.10.2).
    """

    mode: str | None = "peer"
    connect: list[str] = field(default_factory=list)
    listen: list[str] = field(default_factory=list)
    config_file: str | None = None
    scouting: bool = False
    #: Further settings by config path, e.g. ``{"connect/timeout_ms": 3000}``; applied last.
    overrides: dict[str, Any] = field(default_factory=dict)

    def with_message_limit(self, size: int) -> ZenohOptions:
        """These options with Zenoh's ``transport/link/rx/max_message_size`` at ``size`` bytes,
        unless the overrides already set it (see :func:`facesynth.runtime.limits.session_limit`).
        """
        overrides = {MESSAGE_LIMIT_PATH: size, **self.overrides}
        return dataclasses.replace(self, overrides=overrides)

    def config_file_path(self) -> str | None:
        """The config file in force: ``config_file``, else ``$ZENOH_CONFIG``, else none."""
        return self.config_file or os.environ.get("ZENOH_CONFIG") or None

    def effective_mode(self) -> str:
        """The session mode these options give (``mode``, else the config file's, else peer)."""
        try:
            return str(json.loads(self.build().get_json("mode")) or "peer")
        except (ZenohConfigError, ValueError, TypeError):
            return self.mode or "peer"

    def build(self) -> zenoh.Config:
        """The ``zenoh.Config`` these options describe."""
        if self.mode is not None and self.mode not in MODES:
            raise ZenohConfigError(f"unknown Zenoh mode {self.mode!r}; use one of {MODES}")
        path = self.config_file_path()
        try:
            config = zenoh.Config.from_file(path) if path else zenoh.Config()
        except Exception as exc:  # zenoh raises its own ZError for unreadable or invalid files
            raise ZenohConfigError(
                f"cannot load Zenoh config {path}: {zenoh_cause(str(exc))}"
            ) from None
        try:
            if self.mode is not None:
                config.insert_json5("mode", json.dumps(self.mode))
            if self.connect:
                config.insert_json5("connect/endpoints", json.dumps(list(self.connect)))
            if self.listen:
                config.insert_json5("listen/endpoints", json.dumps(list(self.listen)))
            if not self.scouting:
                config.insert_json5("scouting/multicast/enabled", "false")
            _raise_shm_threshold(config)
            config.insert_json5("adminspace/enabled", "true")
            for path, value in self.overrides.items():
                config.insert_json5(path, json.dumps(value))
        except Exception as exc:
            raise ZenohConfigError(f"invalid Zenoh option: {zenoh_cause(str(exc))}") from None
        return config


def _raise_shm_threshold(config: zenoh.Config) -> None:
    """:data:`SHM_THRESHOLD` instead of Zenoh's default (a config file's own value is kept; a
    Zenoh without shared memory has no such setting)."""
    try:
        current = json.loads(config.get_json(SHM_THRESHOLD_PATH))
    except Exception:  # zenoh raises its own ZError for an unknown path
        return
    if current == ZENOH_SHM_THRESHOLD:
        config.insert_json5(SHM_THRESHOLD_PATH, str(SHM_THRESHOLD))


_RUST_PLACE = re.compile(r"\s*at \S+\.rs:\d+\.?")
_OS_ERROR = re.compile(r"\s*\(os error \d+\)")
_RUST_DEBUG = re.compile(r"\b(?:Single|Some)\(([^()]*)\)")


def zenoh_cause(text: str) -> str:
    """Zenoh's error text without the places in Zenoh's Rust sources it was raised at
    (``… at /root/.cargo/…/tcp.rs:61.``) and the OS error numbers: the cause alone."""
    text = _RUST_DEBUG.sub(r"\1", _OS_ERROR.sub("", _RUST_PLACE.sub("", text)))
    return " ".join(text.replace("[", "").replace("]", "").split()).rstrip(" .")


def open_session(options: ZenohOptions) -> zenoh.Session:
    """Open a Zenoh session, turning Zenoh's errors into :class:`ZenohConfigError` (one line:
    the cause, and the option that changes it)."""
    config = options.build()
    try:
        return zenoh.open(config)
    except Exception as exc:
        cause = zenoh_cause(str(exc))
        mode = options.mode or "configured"
        if "Address already in use" in cause:
            where = ", ".join(options.listen) or "the configured endpoints"
            hint = (
                " - another program listens there: choose another endpoint with --listen "
                "(e.g. tcp/127.0.0.1:7448; port 0 picks a free one)"
            )
        else:
            where = ", ".join(options.connect or options.listen) or "the configured endpoints"
            hint = ""
            if options.mode == "client":
                waited = options.overrides.get("connect/timeout_ms")
                within = (
                    f"none answered within {waited / 1000:g} s, --router-timeout S waits longer; "
                    if isinstance(waited, int | float) and waited > 0
                    else ""
                )
                hint = (
                    f" - is a router running there? ({within}start one with: facesynth router; "
                    "or --connect another)"
                )
        raise ZenohConfigError(
            f"cannot open a Zenoh {mode} session ({where}): {cause}{hint}"
        ) from None


def router_locators(session: zenoh.Session, timeout: float = 2.0) -> list[str]:
    """Locators a router session listens on, read from its admin space (``@/<zid>/router``)."""
    zid = str(session.info.zid())
    for reply in session.get(f"@/{zid}/router", timeout=timeout):
        if reply.ok is not None:
            info = json.loads(reply.ok.payload.to_bytes())
            return [str(loc) for loc in info.get("locators", [])]
    return []


class _TransportWatch:
    """Logs the session's transports opening and closing, and follows its link to routers.

    Zenoh reports transport events on its own thread; the handler only updates a
    :class:`RouterLink` and logs. A router's own session logs the sessions it serves instead.
    """

    def __init__(
        self,
        session: zenoh.Session,
        *,
        is_router: bool,
        on_regained: Callable[[], None] | None = None,
    ) -> None:
        self.link = RouterLink()
        self.is_router = is_router
        #: Called (on Zenoh's thread) when a router is gained after none.
        self.on_regained = on_regained
        self._listener: Any = None
        try:
            self._listener = session.info.declare_transport_events_listener(
                self._on_event, history=True
            )
        except Exception as exc:  # pragma: no cover - a Zenoh without transport events
            log.debug("transport events unavailable: %s", exc)

    def _on_event(self, event: Any) -> None:
        now = time.monotonic_ns()
        transport = event.transport
        zid = str(transport.zid)
        whatami = str(transport.whatami).rsplit(".", 1)[-1].lower()
        opened = event.kind == zenoh.SampleKind.PUT
        if self.is_router:
            state = "connected" if opened else "disconnected"
            log.info("%s %s %s", whatami, short_id(zid), state)
            return
        if whatami != "router":
            log.debug("%s %s %s", whatami, short_id(zid), "opened" if opened else "closed")
            return
        gained = opened and not self.link.figures(now).connected
        line = self.link.opened(zid, now) if opened else self.link.closed(zid, now)
        if line:
            log.log(logging.INFO if opened else logging.WARNING, "%s", line)
        if gained and self.on_regained is not None:
            self.on_regained()

    def close(self) -> None:
        listener, self._listener = self._listener, None
        if listener is not None:
            with contextlib.suppress(Exception):  # the session is already closed
                listener.undeclare()


class ZenohBus(Bus):
    """A bus over one Zenoh session; several buses may share a session (``owns_session``).

    It logs losing and regaining the router (``facesynth.link``) and reports it in
    :meth:`link`, which services publish in their stats.
    """

    def __init__(
        self, session: zenoh.Session, *, owns_session: bool = True, mode: str | None = None
    ) -> None:
        self.session = session
        self._owns_session = owns_session
        self._routes = SessionRoutes.attach(session)
        self._outlets: dict[str, Outlet] = {}
        self._subscriptions: list[Subscription] = []
        self._tokens: list[ZenohToken] = []
        self._closed = False
        self._selfcheck: asyncio.Task[None] | None = None
        self._client = mode == "client"  # the self-check's question holds for clients only
        self._watch = _TransportWatch(
            session, is_router=mode == "router", on_regained=self._regained
        )

    def link(self, now_ns: int | None = None) -> LinkFigures | None:
        """The link to the router (``None`` for a router's own session); monotonic time."""
        if self._watch.is_router:
            return None
        return self._watch.link.figures(time.monotonic_ns() if now_ns is None else now_ns)

    def _regained(self) -> None:
        """A router again after none (Zenoh's thread): every publisher looks again at who
        subscribes (:meth:`Outlet.regained`), and every subscription checks it hears
        (:meth:`SessionRoutes.regained`)."""
        for outlet in list(self._outlets.values()):
            outlet.regained()
        self._routes.regained()

    @classmethod
    def open(cls, options: ZenohOptions) -> ZenohBus:
        """Open a session from ``options`` and wrap it."""
        return cls(open_session(options), mode=options.effective_mode())

    def _outlet(self, key: str) -> Outlet:
        outlet = self._outlets.get(key)
        if outlet is None:
            outlet = self._outlets[key] = Outlet(self.session, key)
        return outlet

    def publish(self, key: str, payload: bytes) -> None:
        outlet = self._outlet(key)
        targets = self._routes.targets(key)
        if targets:
            sample = Sample(key, bytes(payload), time.time_ns())
            for feed in targets:
                feed.deliver_local(sample)
        if outlet.wanted():
            outlet.publisher.put(payload)

    def publish_message(self, key: str, message: Any, encode: Callable[[Any], bytes]) -> None:
        outlet = self._outlet(key)
        parcel = Parcel(message, encode)
        targets = self._routes.targets(key)
        if targets:
            sample = Sample(key, parcel, time.time_ns())
            for feed in targets:
                feed.deliver_local(sample)
        if outlet.wanted():
            outlet.publisher.put(parcel.payload())

    def _subscribe(self, key_expr: str, maxsize: int) -> Subscription:
        zenoh.KeyExpr(key_expr)  # a bad key expression fails here, as Zenoh would
        subscription = ZenohSubscription(self._routes.feed(key_expr), maxsize)
        self._subscriptions.append(subscription)
        return subscription

    def declare_token(self, key: str) -> Token:
        token = ZenohToken(self.session, key)
        self._tokens.append(token)
        if self._selfcheck is None and self._client:
            with contextlib.suppress(RuntimeError):  # no event loop: nobody to check
                self._selfcheck = asyncio.get_running_loop().create_task(
                    watch(
                        lambda: router_holds(self.session, token.key) if token.declared else None,
                        lambda: bool((figures := self.link()) and figures.connected),
                        self.declare_anew,
                    )
                )
        return token

    def declare_anew(self) -> None:
        """Declare every token, subscription and publisher of this bus again (its router has
        lost them: :mod:`~facesynth.runtime.bus.zenoh_selfcheck`)."""
        for token in list(self._tokens):
            token.declare_anew()  # a closed one stays closed
        self._routes.declare_anew()
        for outlet in list(self._outlets.values()):
            outlet.declare_anew()

    async def alive(self, key_expr: str, timeout: float = 1.0) -> list[str]:
        def query() -> list[str]:
            replies = self.session.liveliness().get(key_expr, timeout=timeout)
            return sorted({str(r.ok.key_expr) for r in replies if r.ok is not None})

        return await asyncio.to_thread(query)

    async def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        if self._selfcheck is not None:
            self._selfcheck.cancel()
        for subscription in self._subscriptions:
            subscription.close()
        for token in self._tokens:
            token.close()
        for outlet in self._outlets.values():
            outlet.close()
        self._outlets.clear()
        self._watch.close()
        self._routes.detach()
        if self._owns_session:
            await asyncio.to_thread(self.session.close)


def endpoints(values: Sequence[str] | None) -> list[str]:
    """Split repeated or comma-separated endpoint options into a list."""
    out: list[str] = []
    for value in values or ():
        out.extend(part.strip() for part in value.split(",") if part.strip())
    return out
