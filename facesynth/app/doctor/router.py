"""The Zenoh router: whether one answers where the graph looks for it, and how links to it are
secured (plain TCP, TLS, or mutual TLS with a certificate of the rig's CA, as ``facesynth
certs`` makes them; see :mod:`facesynth.app.secure`).

``facesynth run`` starts its own router listening on ``tcp/127.0.0.1:7447``; when something
already listens there it takes a free port on loopback instead (an ``info`` line: run works, but
commands looking on 7447 meet the other program). An explicit ``--listen`` is kept or run
fails, and so is a graph without a sensor's endpoint: there a taken endpoint is the thing to
fix. With ``--mode client`` (or a client config file) the graph needs a router that answers.
"""

from __future__ import annotations

import json
import socket
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from facesynth.app.doctor.needs import RouterNeed
from facesynth.app.doctor.report import Finding
from facesynth.runtime.bus.zenoh_bus import DEFAULT_ROUTER, ZenohConfigError, ZenohOptions

FAMILY = "router"


@dataclass(frozen=True)
class RouterResult:
    """What answered: the router's id, or why no session opened."""

    endpoints: tuple[str, ...]
    security: str
    router: str | None = None
    problem: str | None = None
    occupied: bool = False  # something accepts TCP connections there, router or not


def security_mode(endpoints: Sequence[str], tls: Mapping[str, Any], side: str = "connect") -> str:
    """``plain``, ``TLS`` or ``mutual TLS``: how links on these endpoints are secured, given
    the config's ``transport/link/tls`` settings, for the ``connect`` or ``listen`` side."""
    if not any(e.split("/", 1)[0] in ("tls", "quic") for e in endpoints):
        return "plain"
    mutual = tls.get("enable_mtls") and tls.get(f"{side}_certificate")
    return "mutual TLS" if mutual else "TLS"


def _json(config: Any, path: str) -> Any:
    try:
        return json.loads(config.get_json(path))
    except Exception:  # a path the config does not hold
        return None


def client_options(need: RouterNeed, timeout: float) -> ZenohOptions:
    """Options of a client session to the graph's router that gives up within ``timeout``."""
    base = need.options
    connect = list(base.connect)
    if need.embedded:  # where run's own router will listen: is someone there already?
        connect = list(base.listen) or [DEFAULT_ROUTER]
    options = ZenohOptions(
        mode="client",
        connect=connect,
        config_file=base.config_file,
        overrides={"connect/timeout_ms": round(timeout * 1000), "connect/exit_on_failure": True},
    )
    if not options.connect and options.config_file_path() is None:
        options.connect = [DEFAULT_ROUTER]
    return options


def probe_router(need: RouterNeed, timeout: float = 2.0) -> RouterResult:
    """Open a client session (within ``timeout``) and read the router's id."""
    from facesynth.runtime.bus.zenoh_bus import open_session

    options = client_options(need, timeout)
    try:
        config = options.build()
    except ZenohConfigError as exc:
        return RouterResult((), "unknown", problem=str(exc))
    endpoints = tuple(_json(config, "connect/endpoints") or ())
    tls = _json(config, "transport/link/tls") or {}
    security = security_mode(endpoints, tls)
    if need.embedded:  # run's router: as its own config listens
        try:
            own = need.options.build()
        except ZenohConfigError as exc:
            return RouterResult(endpoints, "unknown", problem=str(exc))
        security = security_mode(endpoints, _json(own, "transport/link/tls") or {}, "listen")
    listening = [_listens(endpoint, timeout) for endpoint in endpoints]
    if endpoints and not any(state is not False for state in listening):
        return RouterResult(endpoints, security, problem="nothing listens there")
    occupied = any(listening)
    try:
        session = open_session(options)
    except ZenohConfigError as exc:
        return RouterResult(endpoints, security, problem=str(exc), occupied=occupied)
    try:
        routers = [str(zid) for zid in session.info.routers_zid()]
    finally:
        session.close()
    if not routers:
        return RouterResult(endpoints, security, problem="no router answered", occupied=occupied)
    return RouterResult(endpoints, security, router=routers[0][:8], occupied=True)


def _listens(endpoint: str, timeout: float) -> bool | None:
    """Whether something accepts TCP connections on a ``tcp/`` or ``tls/`` ``HOST:PORT``
    endpoint (asked at once, without the Zenoh session's retries or a TLS handshake): True,
    False when refused, None for other protocols and for anything less certain."""
    protocol, _, rest = endpoint.partition("/")
    if protocol not in ("tcp", "tls"):
        return None
    host, _, port = rest.split("#", 1)[0].rpartition(":")
    if not port.isdigit():
        return None
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=min(timeout, 1.0)):
            return True
    except ConnectionRefusedError:
        return False
    except OSError:
        return None


def router_findings(result: RouterResult, need: RouterNeed) -> list[Finding]:
    """The router's line (pure): answering or not, judged by what the graph needs."""
    where = ", ".join(result.endpoints) or "the configured endpoints"

    def found(text: str, **judged: Any) -> list[Finding]:
        return [Finding(FAMILY, where, text, **judged)]

    if need.embedded and need.free_port and (result.router is not None or result.occupied):
        who = f"router {result.router}" if result.router is not None else "something"
        return found(
            f"{who} already listens there ({result.security}): run's own router will "
            "take a free port on 127.0.0.1 instead and log it (commands that look on "
            f"{where} meet the other program; --listen chooses run's endpoint)",
            good=None,
        )
    if need.embedded:
        if result.router is not None:
            return found(
                f"router {result.router} already listens there ({result.security}), where "
                "run's own router would",
                good=False,
                needed=True,
                fix="stop it, choose another endpoint with --listen, or use it with "
                f"--mode client --connect {result.endpoints[0] if result.endpoints else '…'}",
            )
        if result.occupied:
            return found(
                f"something already listens there ({result.security}), where run's own "
                f"router would: no session opens to it ({_cause(result.problem)})",
                good=False,
                needed=True,
                fix="stop what listens there (another router, perhaps of a secured rig), or "
                "choose another endpoint with --listen",
            )
        return found(
            f"free: run's own router listens here ({result.security}); no other router answers"
        )
    if result.router is not None:
        return found(f"router {result.router} answers ({result.security})")
    return found(
        f"no router answers ({result.security}): {_cause(result.problem)}",
        good=False,
        needed=True,
        fix="start one (facesynth router, or zenohd with deploy/zenoh-router.json5), or "
        "--connect where it runs; a secured rig needs its certificates (facesynth certs)",
    )


def _cause(problem: str | None) -> str:
    """A session error without the advice after it (the fix says what to do)."""
    return (problem or "no answer").split(" - ", 1)[0]
