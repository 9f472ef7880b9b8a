"""What a multi-process benchmark sees of a rig from its own bus session.

One :class:`RigObserver` follows the rig's stats (each service's own latency window) and the
``…/servo_state`` keys (how far the chain got, which opens and closes the CPU window at chosen
frames), and with ``hops`` also when each frame's message appeared on ``…/points``,
``…/features`` and ``…/servo_commands``, which splits capture → command into its hops. Arrival
times are stamped on Zenoh's receiving thread, as for every facesynth subscriber; frames are not
watched (they are the biggest messages, and their capture time is in every later message).
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from facesynth.app.bench.processes import TICKS
from facesynth.runtime import codec, keys
from facesynth.runtime.bus.base import Bus, Subscription, SubscriptionClosed
from facesynth.runtime.bus.sample import Sample
from facesynth.runtime.tasks import cancel_and_wait
from facesynth.schemas.messages import Features, Points, ServiceStats, ServoCommands

#: The keys whose arrival times split the chain into hops, in chain order.
HOP_STAGES: tuple[keys.Stage, ...] = ("points", "features", "servo_commands", "servo_state")
_TYPES: dict[str, type[Any]] = {
    "points": Points,
    "features": Features,
    "servo_commands": ServoCommands,
    "servo_state": ServoCommands,
}
#: Hop names: from the capture (or the previous key) to the message on this key.
HOP_NAMES = {
    "points": "capture → points",
    "features": "points → features",
    "servo_commands": "features → commands",
    "servo_state": "commands → applied",
}


@dataclass
class Trigger:
    """Calls ``action`` once, when the chain has applied frame ``seq``."""

    seq: int
    action: Callable[[int], None]
    fired_at: int | None = None


@dataclass
class RigObserver:
    """Stats, progress and (optionally) per-hop arrival times of one rig."""

    bus: Bus
    rig: str
    hops: bool = False
    triggers: list[Trigger] = field(default_factory=list)
    #: Without hops, follow this robot's applied commands only (default: every robot's).
    progress_robot: str | None = None
    #: The latest stats of each service instance, by ``service/instance`` (the nodes of one
    #: process share its instance id).
    stats: dict[str, ServiceStats] = field(default_factory=dict)
    last_seq: int = -1
    #: ``arrivals[stage][(robot, seq)]``: when the message of frame ``seq`` arrived (ns).
    arrivals: dict[str, dict[tuple[str, int], int]] = field(default_factory=dict)
    #: ``captures[seq]``: the capture time of frame ``seq`` (from the messages).
    captures: dict[int, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self._subscriptions: list[Subscription] = []
        self._tasks: list[asyncio.Task[None]] = []

    def start(self) -> None:
        """Subscribe and start following."""
        stats = self.bus.subscribe_queued(keys.stats_pattern(self.rig), 4096)
        self._follow(stats, self._on_stats)
        stages = HOP_STAGES if self.hops else ("servo_state",)
        for stage in stages:
            self.arrivals[stage] = {}
            key = keys.robots_pattern(self.rig, stage)
            if not self.hops and self.progress_robot:
                key = keys.stage_key(self.rig, stage, self.progress_robot)
            subscription = self.bus.subscribe_queued(key, 8192)
            self._follow(subscription, functools.partial(self._on_stage, stage))

    def _follow(self, subscription: Subscription, handler: Callable[[Sample], None]) -> None:
        self._subscriptions.append(subscription)

        async def follow() -> None:
            with contextlib.suppress(SubscriptionClosed):
                while True:
                    handler(await subscription.receive())

        self._tasks.append(asyncio.create_task(follow()))

    def _on_stats(self, sample: Sample) -> None:
        with contextlib.suppress(ValueError):
            stats = codec.decode(sample.payload, ServiceStats)
            parsed = keys.parse_service_key(sample.key)
            instance = parsed[2] if parsed else stats.instance
            self.stats[f"{stats.service}/{instance}"] = stats

    def _on_stage(self, stage: str, sample: Sample) -> None:
        try:
            message = codec.decode(sample.payload, _TYPES[stage])
        except ValueError:
            return
        seq = message.seq
        robot = keys.robot_of(sample.key) or ""
        self.arrivals[stage].setdefault((robot, seq), sample.t_received_ns)
        self.captures.setdefault(seq, message.t_capture_ns)
        if stage == "servo_state" and seq > self.last_seq:
            self.last_seq = seq
            for trigger in self.triggers:
                if trigger.fired_at is None and seq >= trigger.seq:
                    trigger.fired_at = seq
                    trigger.action(seq)

    def dropped(self) -> int:
        """Messages this observer's own mailboxes lost (then its hop figures are incomplete)."""
        return sum(sub.dropped for sub in self._subscriptions)

    async def close(self) -> None:
        """Stop following."""
        for subscription in self._subscriptions:
            subscription.close()
        await cancel_and_wait(self._tasks)

    def hop_latencies(self, from_seq: int = 0) -> dict[str, np.ndarray]:
        """Per hop, the milliseconds of each frame (``from_seq`` on) seen on both of its ends."""
        out: dict[str, np.ndarray] = {}
        previous: dict[tuple[str, int], int] | None = None
        for stage in HOP_STAGES:
            here = self.arrivals.get(stage, {})
            values = []
            for (robot, seq), t in here.items():
                if seq < from_seq:
                    continue
                if previous is None:
                    start = self.captures.get(seq)
                else:
                    # Hops before the translator are shared by every robot (key robot "").
                    start = previous.get((robot, seq), previous.get(("", seq)))
                if start:
                    values.append((t - start) / 1e6)
            out[HOP_NAMES[stage]] = np.array(values)
            previous = here
        return out

    def tail_hops(self, from_seq: int = 0, share: float = 0.01) -> dict[str, tuple[float, float]]:
        """Per hop, its median over every frame and over the slowest ``share`` of frames
        (capture → applied): which hop grows when a frame is late."""
        applied = self.arrivals.get("servo_state", {})
        totals = {
            key: (t - self.captures[key[1]]) / 1e6
            for key, t in applied.items()
            if key[1] >= from_seq and key[1] in self.captures
        }
        if not totals:
            return {}
        ordered = sorted(totals, key=totals.__getitem__)
        slow = set(ordered[-max(1, round(len(ordered) * share)) :])
        out = {}
        chain: list[dict[tuple[str, int], int]] = [self.arrivals.get(s, {}) for s in HOP_STAGES]
        for index, stage in enumerate(HOP_STAGES):
            every, tail = [], []
            for key in ordered:
                seq = key[1]
                end = chain[index].get(key, chain[index].get(("", seq)))
                if index == 0:
                    start = self.captures.get(seq)
                else:
                    start = chain[index - 1].get(key, chain[index - 1].get(("", seq)))
                if end is None or not start:
                    continue
                value = (end - start) / 1e6
                every.append(value)
                if key in slow:
                    tail.append(value)
            out[HOP_NAMES[stage]] = (
                float(np.median(every)) if every else float("nan"),
                float(np.median(tail)) if tail else float("nan"),
            )
        return out


def machine_busy() -> tuple[float, float] | None:
    """``(busy, total)`` CPU seconds of the whole machine so far (from ``/proc/stat``)."""
    try:
        with open("/proc/stat", encoding="ascii") as handle:
            first = handle.readline().split()
    except OSError:
        return None
    values = [int(v) for v in first[1:9]]  # user nice system idle iowait irq softirq steal
    idle = values[3] + values[4]
    return (sum(values) - idle) / TICKS, sum(values) / TICKS


def loadavg() -> float:
    """The machine's one-minute load average (NaN where unknown)."""
    try:
        with open("/proc/loadavg", encoding="ascii") as handle:
            return float(handle.read().split()[0])
    except (OSError, ValueError, IndexError):
        return float("nan")


def now_ns() -> int:
    """Wall-clock nanoseconds (the clock every message's capture time uses)."""
    return time.time_ns()
