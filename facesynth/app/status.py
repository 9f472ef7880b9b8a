"""``facesynth status`` and ``facesynth health``: what is alive on a rig, and how it is doing."""

from __future__ import annotations

import argparse
import asyncio
import logging
import time
from typing import Any

from facesynth.app import wiring
from facesynth.runtime import keys
from facesynth.runtime.bus.zenoh_bus import ZenohBus
from facesynth.runtime.service import run_async

log = logging.getLogger("facesynth")


def cmd_status(args: argparse.Namespace) -> int:
    """``facesynth status``: live services and their latest stats."""
    from facesynth.app.engine.router import joined_bus
    from facesynth.runtime.codec import decode
    from facesynth.schemas.messages import ServiceStats

    options = wiring.zenoh_options(args)
    rig = None if args.all_rigs else args.rig

    async def main() -> tuple[list[str], dict[str, ServiceStats]]:
        async with joined_bus(options) as bus:
            subscription = bus.subscribe_queued(keys.stats_pattern(rig), 256)
            alive = await bus.alive(keys.health_pattern(rig), timeout=min(args.timeout, 2.0))
            stats: dict[str, ServiceStats] = {}
            deadline = time.monotonic() + args.timeout
            while (remaining := deadline - time.monotonic()) > 0:
                try:
                    async with asyncio.timeout(remaining):
                        sample = await subscription.receive()
                except TimeoutError:
                    break
                try:
                    stats[sample.key] = decode(sample.payload, ServiceStats)
                except ValueError as exc:
                    log.warning("ignored stats on %s: %s", sample.key, exc)
            return alive, stats

    alive, stats = run_async(main())
    print(format_status(alive, stats))
    return 0 if alive else 1


def format_status(alive: list[str], stats: dict[str, Any]) -> str:
    """A table of live services with their latest stats (``stale``: inputs dropped because
    their frame was captured longer ago than the stage's limit); the state column is
    :func:`describe_state`."""
    by_instance = {keys.parse_service_key(k): s for k, s in stats.items()}
    header = (
        f"{'rig':<12} {'service':<11} {'instance':<28} {'rate Hz':>8} {'p50 ms':>8} "
        f"{'p99 ms':>8} {'recv':>7} {'sent':>7} {'drop':>5} {'rej':>5} {'stale':>5} {'router':<21} "
        f"{'RSS MB':>7}  state"
    )
    lines = [header]
    for key in alive:
        parsed = keys.parse_service_key(key)
        if parsed is None:
            continue
        s = by_instance.get(parsed)
        if s is None:
            lines.append(f"{parsed[0]:<12} {parsed[1]:<11} {parsed[2]:<28} {'(no stats yet)':>8}")
            continue
        p50 = f"{s.latency_p50_ms:.2f}" if s.latency_p50_ms is not None else "-"
        p99 = f"{s.latency_p99_ms:.2f}" if s.latency_p99_ms is not None else "-"
        stale = getattr(s, "stale", 0)  # inputs dropped for their capture age
        lines.append(
            f"{parsed[0]:<12} {parsed[1]:<11} {parsed[2]:<28} {s.rate_hz:>8.1f} {p50:>8} {p99:>8} "
            f"{s.received:>7} {s.published:>7} {s.dropped:>5} {s.rejected:>5} {stale:>5} "
            f"{describe_link(s):<21} {s.rss_mb:>7.1f}  {describe_state(s)}"
        )
    if len(lines) == 1:
        lines.append("(no live services)")
    return "\n".join(lines)


def cmd_health(args: argparse.Namespace) -> int:
    """``facesynth health``: 0 when this host's service is live on the rig's router, else 1.

    Unhealthy is exit status 1 whatever the reason (no router, no token), as container health
    checks expect; the reason is printed.
    """
    from facesynth.runtime.bus.zenoh_bus import ZenohConfigError
    from facesynth.runtime.service import host_id

    # A one-shot tool: it gives up on an absent router after --router-timeout (default 2 s),
    # whatever the config file says (facesynth.app.router_wait).
    options = wiring.zenoh_options(args)
    host = args.host or host_id()

    async def main() -> tuple[bool, str]:
        try:
            bus = await asyncio.to_thread(ZenohBus.open, options)
        except ZenohConfigError as exc:
            return False, str(exc)
        try:
            if args.router:
                routers = [str(z) for z in bus.session.info.routers_zid()]
                if routers:
                    return True, f"router {routers[0][:8]} accepts sessions"
                return False, "no router answered"
            alive = await bus.alive(keys.health_pattern(args.rig), timeout=args.timeout)
            mine = [
                key
                for key in alive
                if (parsed := keys.parse_service_key(key)) and parsed[2].startswith(f"{host}-")
            ]
            if mine:
                return True, " ".join(mine)
            return False, f"no live service of host {host!r} on the router"
        finally:
            await bus.close()

    healthy, reason = run_async(main())
    print(f"{'healthy' if healthy else 'unhealthy'}: {reason}")
    return 0 if healthy else 1


def describe_state(stats: Any) -> str:
    """What a service is doing, from its stats: publishing, idle (for how long) or without
    output yet, then its own note (a driver's link, ``stopped``) if it has one."""
    idle = getattr(stats, "idle_s", None)
    if stats.published == 0:
        state = "no output yet"
    elif stats.rate_hz > 0:
        state = "publishing"
    elif idle is not None:
        state = f"idle {idle:.0f} s"
    else:  # a service older than idle_s
        state = "idle"
    return f"{state}; {stats.note}" if stats.note else state


def describe_link(stats: Any) -> str:
    """A service's link to its router, from its stats: up, down, and how often it was lost."""
    connected = getattr(stats, "router_connected", None)
    if connected is None:
        return "-"
    state = "up" if connected else "down"
    if stats.router_losses:  # how often it was lost, and the time spent without it
        state += f", lost {stats.router_losses}x ({stats.router_offline_s:.1f} s)"
    return state
