"""Which fault comes next, pure: the soak's round-robin and what an injected fault was.

The kinds take turns (``KINDS``); each kind takes turns over its own targets: kill -9 over the
stages and the router, the stall over the stalled stage, the flood over the keys, the oversized
burst over (key, payload) pairs. So every target of every kind comes up in a long enough soak,
and a short one still sees each kind.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass

#: The fault kinds, in the order they take turns.
KINDS = ("kill", "stall", "flood", "oversized")
#: With ``--link-cuts`` (root): the board's link taken down for ``CUT_S`` seconds, too.
ALL_KINDS = (*KINDS, "cut")
#: What kill -9 takes turns over (the router among the stages).
KILL_TARGETS = ("translator", "router", "points", "control", "features", "sensor")
#: Frozen for ``STALL_S`` seconds (SIGSTOP, then SIGCONT).
STALL_TARGETS = ("points",)
#: The keys flooded (a stage's key, or ``stats``).
FLOOD_TARGETS = ("input", "points", "features", "servo_commands", "servo_state", "stats")
#: (key, payload) of an oversized burst: tests/faults/big_sender.py's kinds (an 18 MB
#: million-entry command, 18 MB of zeros, a 4 MB JPEG frame declaring 16000x16000 pixels).
OVERSIZED_TARGETS = ("servo_commands:commands", "features:bytes", "input:jpeg")
#: The link cut: the IP router's link to the board host (tests/netns).
CUT_TARGETS = ("board",)


@dataclass(frozen=True)
class Fault:
    """One injected fault: its kind and target, and when it began and ended (wall clock, ns;
    a kill ends when the process it killed is ready again)."""

    kind: str
    target: str
    start_ns: int
    end_ns: int
    detail: str = ""


def rounds(
    kinds: Sequence[str] = KINDS,
    targets: dict[str, Sequence[str]] | None = None,
) -> Iterator[tuple[str, str]]:
    """(kind, target) pairs forever: kinds in turn, each kind's targets in turn."""
    chosen = {
        "kill": KILL_TARGETS,
        "stall": STALL_TARGETS,
        "flood": FLOOD_TARGETS,
        "oversized": OVERSIZED_TARGETS,
        "cut": CUT_TARGETS,
        **(targets or {}),
    }
    for kind in kinds:
        if kind not in chosen or not chosen[kind]:
            raise ValueError(f"no targets for fault kind {kind!r}")
    turn = dict.fromkeys(kinds, 0)
    while True:
        for kind in kinds:
            options = chosen[kind]
            yield kind, options[turn[kind] % len(options)]
            turn[kind] += 1
