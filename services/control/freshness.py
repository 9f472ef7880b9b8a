"""Whether a servo command is fresh enough to execute, pure: order per sender, age per host clock.

A translator stamps each command with ``sender`` (its instance), ``sender_seq`` (1, 2, …),
``sent_ns`` (its wall clock at publication) and ``sender_host`` (whose clock that is). The
control interface refuses (:class:`StaleCommand`):

* **an older command**: not newer than the last one applied from the same sender, neither by
  ``sender_seq`` nor by ``sent_ns`` (so a restarted sender whose count starts again is newer,
  while a held-back message of the same sender is not);
* **an old command**: older than the profile's ``max_command_age_s``.

**Clocks.** ``sent_ns`` is read on the sender's host and compared with the controller's wall
clock at arrival, and the two hosts' clocks may differ by any amount. So the controller never
trusts the difference itself; per sender host it keeps the smallest ``arrival - sent`` seen over
the last ``window_s`` (30 s, in 1 s buckets, measured on its own monotonic clock): that is the
clock offset plus the fastest delivery, and a command's *age* is how much later than that it
arrived. A backlog that a healed link delivers at once arrives seconds later than usual and is
dropped, whatever the clocks say; a live stream is never aged by the offset. The first command
from a host the controller has not heard from sets that baseline (a command from the
controller's own host starts from offset 0, so even the first one is aged exactly). The window
follows slow clock drift; the newest bucket never expires, so a backlog after a long silence is
still measured against the last live baseline.

Two things one-way stamps cannot tell apart are a sender clock stepped back (NTP) and a link
that stays slower for good: both make every command look old. After ``relearn_s`` (2 s) in
which every command from a host looked old (and at least ``relearn_count`` arrived), the
controller takes the new delay as the baseline and says so; a backlog drains in far less than
that. Commands without the stamps (older translators) are executed unaged; the controller says
so once.
"""

from __future__ import annotations

import collections
from dataclasses import dataclass, field

from schemas.messages import ServoCommands

#: The baseline of a host is the smallest offset over this long (seconds).
WINDOW_S = 30.0
#: Width of one bucket of the window (seconds).
BUCKET_S = 1.0
#: After this long (seconds) with nothing but old commands from a host, its baseline is re-learnt.
RELEARN_S = 2.0
#: ... provided at least this many commands arrived meanwhile.
RELEARN_COUNT = 10
#: How many senders' last commands are remembered.
SENDERS = 64


class StaleCommand(ValueError):
    """A command that must not be executed because it is old or older than one applied."""


@dataclass(frozen=True, slots=True)
class Arrival:
    """When a command reached the controller: its wall clock (comparable with the sender's,
    up to their offset) and its monotonic clock (for intervals)."""

    wall_ns: int
    mono_ns: int


@dataclass(frozen=True, slots=True)
class Verdict:
    """A fresh command: its age (seconds; ``None`` when it carries no stamps), whether its
    sender is not the one of the previous command, and a line worth logging (or empty)."""

    age_s: float | None
    new_sender: bool = False
    note: str = ""


@dataclass
class _HostClock:
    """The offset baseline of one sender host, and its run of old commands."""

    buckets: collections.deque[list[int]] = field(default_factory=collections.deque)
    stale_since_ns: int | None = None
    stale_count: int = 0

    def baseline(self) -> int:
        return min(offset for _, offset in self.buckets)

    def add(self, mono_ns: int, offset_ns: int) -> None:
        bucket_ns = round(BUCKET_S * 1e9)
        if self.buckets and mono_ns - self.buckets[-1][0] < bucket_ns:
            self.buckets[-1][1] = min(self.buckets[-1][1], offset_ns)
        else:
            self.buckets.append([mono_ns, offset_ns])
        newest = self.buckets[-1][0]
        while len(self.buckets) > 1 and newest - self.buckets[0][0] > WINDOW_S * 1e9:
            self.buckets.popleft()

    def restart(self, mono_ns: int, offset_ns: int) -> None:
        self.buckets = collections.deque([[mono_ns, offset_ns]])
        self.stale_since_ns, self.stale_count = None, 0


class Freshness:
    """Decides, command by command, whether it is fresh (see the module doc)."""

    def __init__(self, max_age_s: float, own_host: str = "") -> None:
        if not max_age_s > 0:
            raise ValueError("the command age limit must be positive")
        self.max_age_ns = round(max_age_s * 1e9)
        self.own_host = own_host
        self._hosts: dict[str, _HostClock] = {}
        self._last: collections.OrderedDict[str, tuple[int, int]] = collections.OrderedDict()
        self._sender: str | None = None
        self.unstamped = 0

    def check(self, commands: ServoCommands, arrival: Arrival) -> Verdict:
        """The verdict on ``commands`` arrived at ``arrival``, or raise :class:`StaleCommand`.

        A fresh command counts as applied from here on (for the order of its sender).
        """
        sender = commands.sender
        if not sender or commands.sent_ns <= 0:
            self.unstamped += 1
            note = ""
            if self.unstamped == 1:
                note = "commands without send stamps (an older translator?): executed unaged"
            return self._fresh(commands, None, note)
        last = self._last.get(sender)
        if last is not None and commands.sender_seq <= last[0] and commands.sent_ns <= last[1]:
            raise StaleCommand(
                f"command {commands.sender_seq} of {sender} is not newer than "
                f"{last[0]}, already applied"
            )
        offset = arrival.wall_ns - commands.sent_ns
        clock = self._hosts.get(commands.sender_host)
        if clock is None:
            clock = self._hosts[commands.sender_host] = _HostClock()
            same = bool(self.own_host) and commands.sender_host == self.own_host
            clock.add(arrival.mono_ns, 0 if same else offset)
        age = offset - clock.baseline()
        note = ""
        if age > self.max_age_ns:
            if clock.stale_since_ns is None:
                clock.stale_since_ns = arrival.mono_ns
            clock.stale_count += 1
            waited = arrival.mono_ns - clock.stale_since_ns
            if waited < RELEARN_S * 1e9 or clock.stale_count < RELEARN_COUNT:
                raise StaleCommand(
                    f"command {commands.sender_seq} of {sender} is {age / 1e9:.3f} s old "
                    f"(limit {self.max_age_ns / 1e9:g} s)"
                )
            note = (
                f"every command from host {commands.sender_host!r} looked about "
                f"{age / 1e9:.2f} s old for {waited / 1e9:.1f} s: taking that as its clock "
                "offset from now on (a stepped clock, or a link that stays slower)"
            )
            clock.restart(arrival.mono_ns, offset)
            age = 0
        else:
            clock.stale_since_ns, clock.stale_count = None, 0
            clock.add(arrival.mono_ns, offset)
        self._last[sender] = (commands.sender_seq, commands.sent_ns)
        self._last.move_to_end(sender)
        while len(self._last) > SENDERS:
            self._last.popitem(last=False)
        return self._fresh(commands, max(age, 0) / 1e9, note)

    def _fresh(self, commands: ServoCommands, age_s: float | None, note: str) -> Verdict:
        new_sender = self._sender is not None and commands.sender != self._sender
        self._sender = commands.sender
        return Verdict(age_s, new_sender, note)
