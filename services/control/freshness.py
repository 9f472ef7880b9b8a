"""Whether a servo command is fresh enough to execute, pure: order per sender, age per host clock.

A translator stamps each command with ``sender`` (its instance), ``sender_seq`` (1, 2, …),
``sent_ns`` (its wall clock at publication) and ``sender_host`` (whose clock that is). The
control interface refuses (:class:`StaleCommand`):

* **an older command**: not newer than the last one applied from the same sender, neither by
  ``sender_seq`` nor by ``sent_ns`` (so a restarted sender whose count starts again is newer,
  while a held-back message of the same sender is not);
* **an old command**: older than the profile's ``max_command_age_s``.

**Clocks.** ``sent_ns`` is read on the sender's host and compared with the controller's wall
clock at arrival. A command from the controller's own host is aged exactly (one clock: no
offset to learn, so no load and no restart can make an old command look young). Another
host's clock may differ from the controller's by any amount, so the controller never trusts the
difference itself; per sender host it keeps the smallest ``arrival - sent`` seen over the last
``window_s`` (30 s, in 1 s buckets, measured on its own monotonic clock, and rising no faster
than a clock drifts): that is the clock offset plus the fastest delivery, and a command's *age*
is how much later than that it arrived. A backlog that a healed link delivers at once arrives
seconds later than usual and is dropped, whatever the clocks say; a live stream is never aged
by the offset. The first command from a host the controller has not heard from sets that
baseline. The newest bucket never expires, so a backlog after a long silence is still measured
against the last live baseline.

Two things one-way stamps cannot tell apart are a sender clock stepped back (NTP) and a link
that stays slower for good: both make every command look old. After ``relearn_s`` (2 s) in
which every command from a host looked old (and at least ``relearn_count`` arrived), the
controller takes the fastest delay of that run as the baseline and says so; a backlog drains
in far less than that. The controller's own clock is never re-learnt. Commands without the
stamps (older translators) are executed unaged; the controller says so once.

**From capture.** A command is also refused (:class:`StaleCapture`) when its frame was
captured longer than ``max_command_age_s`` ago: a stage upstream of the translator that stalls
(points frozen for seconds) lets its backlog go afterwards, and the translator sends it on at
once, fresh by ``sent_ns``. The frame's ``t_capture_ns`` is read on ``capture_host``
(:mod:`facesynth.runtime.capture_age`, whose module doc has the rule): exactly when that is the
controller's own host, from the first command after any restart; on another host only once its
clock is vouched for, so a capture host first seen is on probation (``PROBATION_S``, 1 s, and
10 commands: none is executed while its offset is learnt, so a backlog let go as the
controller starts cannot set the baseline). The capture host and the sender may be different
machines. The first of a run of such commands says so once, the first fresh one after it how
many were dropped. Commands without a capture host (older senders, replays, ``--fast``
sensors) are not aged from capture. The verdict says until when the command stays young
(``capture_deadline_ns``), so the controller judges it again just before its driver writes.
"""

from __future__ import annotations

import collections
from dataclasses import dataclass

from facesynth.runtime.capture_age import (
    PROBATION_S,
    RELEARN_COUNT,
    RELEARN_S,
    WINDOW_S,
    CaptureAge,
    OffsetBaseline,
    learn_host,
)
from facesynth.schemas.messages import ServoCommands

__all__ = [
    "PROBATION_S",
    "RELEARN_COUNT",
    "RELEARN_S",
    "SENDERS",
    "WINDOW_S",
    "Arrival",
    "Freshness",
    "StaleCapture",
    "StaleCommand",
    "Verdict",
]

#: How many senders' last commands are remembered.
SENDERS = 64


class StaleCommand(ValueError):
    """A command that must not be executed because it is old or older than one applied."""


class StaleCapture(StaleCommand):
    """A command whose frame was captured longer ago than the limit (an upstream stall);
    ``note`` is a line worth logging, on the first of a run only."""

    def __init__(self, message: str, note: str = "") -> None:
        super().__init__(message)
        self.note = note


@dataclass(frozen=True, slots=True)
class Arrival:
    """When a command reached the controller: its wall clock (comparable with the sender's,
    up to their offset) and its monotonic clock (for intervals); ``taken_ns`` is the wall clock
    when the controller took it from its input queue to execute it (0: as it arrived), from
    which its capture is aged (a command may wait in the queue too)."""

    wall_ns: int
    mono_ns: int
    taken_ns: int = 0


@dataclass(frozen=True, slots=True)
class Verdict:
    """A fresh command: its age (seconds; ``None`` when it carries no stamps), whether its
    sender is not the one of the previous command, a line worth logging (or empty), its
    age since capture (seconds; ``None`` when it is not aged from capture), and the controller's
    wall clock (ns) after which its capture is too old (``None``: not aged from capture)."""

    age_s: float | None
    new_sender: bool = False
    note: str = ""
    capture_age_s: float | None = None
    capture_deadline_ns: int | None = None


class Freshness:
    """Decides, command by command, whether it is fresh (see the module doc)."""

    def __init__(self, max_age_s: float, own_host: str = "") -> None:
        if not max_age_s > 0:
            raise ValueError("the command age limit must be positive")
        self.max_age_ns = round(max_age_s * 1e9)
        self.own_host = own_host
        self.capture = CaptureAge(max_age_s, own_host, what="command", probation_s=PROBATION_S)
        self._hosts: dict[str, OffsetBaseline] = {}
        self._last: collections.OrderedDict[str, tuple[int, int]] = collections.OrderedDict()
        self._sender: str | None = None
        self.unstamped = 0

    def check(self, commands: ServoCommands, arrival: Arrival) -> Verdict:
        """The verdict on ``commands`` arrived at ``arrival``, or raise :class:`StaleCommand`
        (:class:`StaleCapture` when its frame was captured too long ago).

        A fresh command counts as applied from here on (for the order of its sender).
        """
        sender = commands.sender
        if not sender or commands.sent_ns <= 0:
            self.unstamped += 1
            note = ""
            if self.unstamped == 1:
                note = "commands without send stamps (an older translator?): executed unaged"
            return self._fresh(commands, arrival, None, note)
        last = self._last.get(sender)
        if last is not None and commands.sender_seq <= last[0] and commands.sent_ns <= last[1]:
            raise StaleCommand(
                f"command {commands.sender_seq} of {sender} is not newer than "
                f"{last[0]}, already applied"
            )
        offset = arrival.wall_ns - commands.sent_ns
        clock = learn_host(
            self._hosts, commands.sender_host, self.own_host, offset, arrival.mono_ns
        )
        judged = clock.judge(offset, arrival.mono_ns, self.max_age_ns)
        if judged.old and judged.why == "future":
            raise StaleCommand(
                f"command {commands.sender_seq} of {sender} was sent "
                f"{-judged.age_ns / 1e9:.3f} s in the future by this host's own clock "
                "(a clock stepped back?)"
            )
        if judged.old:
            raise StaleCommand(
                f"command {commands.sender_seq} of {sender} is {judged.age_ns / 1e9:.3f} s old "
                f"(limit {self.max_age_ns / 1e9:g} s)"
            )
        note = ""
        if judged.relearnt:
            note = (
                f"every command from host {commands.sender_host!r} looked about "
                f"{judged.looked_ns / 1e9:.2f} s old for {judged.waited_ns / 1e9:.1f} s: taking "
                "that as its clock offset from now on (a stepped clock, or a link that stays "
                "slower)"
            )
        verdict = self._fresh(commands, arrival, judged.age_ns / 1e9, note)
        self._last[sender] = (commands.sender_seq, commands.sent_ns)
        self._last.move_to_end(sender)
        while len(self._last) > SENDERS:
            self._last.popitem(last=False)
        return verdict

    def order_of(self, sender: str) -> tuple[str | None, str, tuple[int, int] | None]:
        """What a command of ``sender`` changes of the order (to withdraw it later)."""
        return self._sender, sender, self._last.get(sender)

    def restore_order(self, order: tuple[str | None, str, tuple[int, int] | None]) -> None:
        """Undo a command's mark on the order (:meth:`order_of`, taken before it)."""
        self._sender, sender, last = order
        if last is None:
            self._last.pop(sender, None)
        else:
            self._last[sender] = last

    def _fresh(
        self, commands: ServoCommands, arrival: Arrival, age_s: float | None, note: str
    ) -> Verdict:
        """The verdict on a command fresh by its sender's stamps, once aged from capture."""
        captured = self.capture.check(
            commands.t_capture_ns,
            commands.capture_host,
            arrival.taken_ns or arrival.wall_ns,
            arrival.mono_ns,
        )
        if captured.old:
            who = f"command {commands.sender_seq} of {commands.sender or 'an unstamped sender'}"
            if captured.age_s is None:  # its capture host's clock is still being learnt
                why = f"was captured on {commands.capture_host!r}, whose clock is being learnt"
            elif captured.age_s < 0:
                why = f"was captured {-captured.age_s:.3f} s in the future by this host's clock"
            else:
                why = f"was captured {captured.age_s:.3f} s ago"
            raise StaleCapture(
                f"{who} (frame {commands.seq}) {why} (limit {self.max_age_ns / 1e9:g} s)",
                captured.note,
            )
        new_sender = self._sender is not None and commands.sender != self._sender
        self._sender = commands.sender
        notes = "; ".join(line for line in (note, captured.note) if line)
        return Verdict(age_s, new_sender, notes, captured.age_s, captured.deadline_ns)
