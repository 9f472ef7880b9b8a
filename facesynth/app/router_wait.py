"""How each kind of command waits for its Zenoh router: one rule per kind, said in ``--help``.

- **Services and recorders** (the five stages, ``record``, ``inspect``) run for a long time: a
  client started before its router waits for it as long as it takes, retrying with backoff
  (0.1 s, doubling up to 1 s), and says so once.
- **One-shot tools** (``status``, ``health``, ``replay``) answer now or not at all: they wait at
  most :data:`ONE_SHOT_WAIT_S` seconds, retrying the same way, then fail with one line.
- **Commands with their own router** (``run``, ``router``, ``console``, ``learn``, ``doctor``)
  start a router: there is none to wait for, and they take no ``--router-timeout``.

``--router-timeout S`` means the same wherever it is accepted: wait at most S seconds for the
router at start, retrying with backoff (0: fail at once), then fail with one line naming the
endpoints (exit 2; ``health`` exits 1, as a container health check does). It applies over a
Zenoh config file's own setting.
"""

from __future__ import annotations

import enum
from typing import Final

from facesynth.app.stages.registry import STAGES


class RouterWait(enum.Enum):
    """How a kind of command waits for its router at start."""

    #: As long as it takes (``--router-timeout`` bounds it).
    WAITS = "waits"
    #: At most :data:`ONE_SHOT_WAIT_S` (``--router-timeout`` changes it).
    ONE_SHOT = "one-shot"
    #: Starts its own router: nothing to wait for.
    OWN_ROUTER = "own router"


#: How long a one-shot tool waits for its router when not told (seconds).
ONE_SHOT_WAIT_S: Final = 2.0

#: Every command that opens a Zenoh session, by kind (a stage's command is a service).
KINDS: Final = {
    **dict.fromkeys((*STAGES.names(), "record", "inspect"), RouterWait.WAITS),
    **dict.fromkeys(("status", "health", "replay"), RouterWait.ONE_SHOT),
    **dict.fromkeys(("run", "router", "console", "learn", "doctor"), RouterWait.OWN_ROUTER),
}


def kind_of(command: str | None) -> RouterWait | None:
    """The kind of ``command`` (a sub-command's name), or None for one that opens no session;
    the command of a stage registered after :data:`KINDS` was made is a service too."""
    if not command:
        return None
    if command in KINDS:
        return KINDS[command]
    return RouterWait.WAITS if command in STAGES.names() else None


def timeout_help(kind: RouterWait, command: str = "") -> str:
    """The ``--router-timeout`` help of a kind of command (none has its own router)."""
    then = "then 'unhealthy: …', exit 1" if command == "health" else "then exit 2 with one line"
    if kind is RouterWait.WAITS:
        return (
            "seconds to wait for the router at start (default: as long as it takes, retrying "
            f"with backoff, said once; 0: fail at once), {then}"
        )
    return (
        f"seconds to wait for the router (default {ONE_SHOT_WAIT_S:g}, retrying with backoff; "
        f"0: fail at once), {then}"
    )


def group_description(kind: RouterWait) -> str:
    """What the command's Zenoh options group says about its router."""
    if kind is RouterWait.WAITS:
        return (
            "A service: a client started before its router waits for it as long as it takes "
            "(retrying with backoff; --router-timeout bounds the wait)."
        )
    if kind is RouterWait.ONE_SHOT:
        return (
            f"A one-shot tool: it waits at most {ONE_SHOT_WAIT_S:g} s for its router "
            "(--router-timeout), then fails with one line."
        )
    return (
        "It runs on a Zenoh router of its own (doctor: checks run's), so it waits for none and "
        "takes no --router-timeout."
    )
