"""How old a message is since its frame was captured, pure: a clock offset learnt per host.

Every message derived from a frame carries the frame's ``t_capture_ns`` (wall clock of the host
named by ``capture_host``). Comparing it with a receiver's own wall clock needs the two clocks'
offset, which the receiver never trusts: per host it keeps the smallest ``arrival - stamp``
seen over the last ``WINDOW_S`` seconds (:class:`OffsetBaseline`, in ``BUCKET_S`` buckets of
its own monotonic clock). That is the offset plus the fastest way through, and a message's
*age* is how much later than that it arrived. A backlog that an upstream stage lets go after a
stall arrives seconds later than usual and is old, whatever the clocks say; a live stream is
never aged by the offset. A stamp from the receiver's own host starts from offset 0 (even the
first message is aged exactly); another host's first message sets its baseline. The window
follows slow drift; the newest bucket never expires.

A clock stepped back and a way that stays slower for good both make every message look old:
after ``RELEARN_S`` with nothing but old messages from a host (and at least ``RELEARN_COUNT``
of them) the new delay becomes the baseline, and the verdict says so.

:class:`CaptureAge` applies this to capture stamps, with the episodes a log needs: the first
old message of a run says so once, the first fresh one after it says how many were dropped.
Messages without a capture host (older senders, replays of recordings, ``--fast`` sensors whose
frames wait for credit by design) are not aged. The controller ages its senders' ``sent_ns``
with the same :class:`OffsetBaseline` (:mod:`services.control.freshness`). Time is data: the
caller passes its wall and monotonic clocks' readings in nanoseconds.
"""

from __future__ import annotations

import collections
from dataclasses import dataclass, field

#: The baseline of a host is the smallest offset over this long (seconds).
WINDOW_S = 30.0
#: Width of one bucket of the window (seconds).
BUCKET_S = 1.0
#: After this long (seconds) with nothing but old messages from a host, its baseline is re-learnt.
RELEARN_S = 2.0
#: ... provided at least this many messages arrived meanwhile.
RELEARN_COUNT = 10
#: The default capture age limit of the stages that know no profile (points, features: their
#: node option ``max_input_age_s``): the profiles' default ``max_command_age_s``.
DEFAULT_MAX_AGE_S = 0.25
#: How many capture hosts are remembered.
HOSTS = 64


@dataclass(frozen=True, slots=True)
class Judged:
    """An offset judged against a baseline: the age (ns, at least 0), whether it is over the
    limit, and whether the baseline was just re-learnt from it (a stepped clock)."""

    age_ns: int
    old: bool
    relearnt: bool = False
    #: For a re-learnt baseline: how long, and how old, everything looked.
    waited_ns: int = 0
    looked_ns: int = 0


@dataclass
class OffsetBaseline:
    """The offset baseline of one host (see the module doc), and its run of old messages."""

    buckets: collections.deque[list[int]] = field(default_factory=collections.deque)
    stale_since_ns: int | None = None
    stale_count: int = 0

    def baseline(self) -> int:
        """The smallest offset in the window (ns)."""
        return min(offset for _, offset in self.buckets)

    def add(self, mono_ns: int, offset_ns: int) -> None:
        """Take an offset seen at ``mono_ns`` into the window."""
        bucket_ns = round(BUCKET_S * 1e9)
        if self.buckets and mono_ns - self.buckets[-1][0] < bucket_ns:
            self.buckets[-1][1] = min(self.buckets[-1][1], offset_ns)
        else:
            self.buckets.append([mono_ns, offset_ns])
        newest = self.buckets[-1][0]
        while len(self.buckets) > 1 and newest - self.buckets[0][0] > WINDOW_S * 1e9:
            self.buckets.popleft()

    def restart(self, mono_ns: int, offset_ns: int) -> None:
        """Forget the window: ``offset_ns`` is the baseline from now on."""
        self.buckets = collections.deque([[mono_ns, offset_ns]])
        self.stale_since_ns, self.stale_count = None, 0

    def judge(self, offset_ns: int, mono_ns: int, max_age_ns: int) -> Judged:
        """Age ``offset_ns`` (seen at ``mono_ns``) and learn from it: an old one only counts
        toward a re-learnt baseline, a fresh one joins the window."""
        age = offset_ns - self.baseline()
        if age <= max_age_ns:
            self.stale_since_ns, self.stale_count = None, 0
            self.add(mono_ns, offset_ns)
            return Judged(max(age, 0), old=False)
        if self.stale_since_ns is None:
            self.stale_since_ns = mono_ns
        self.stale_count += 1
        waited = mono_ns - self.stale_since_ns
        if waited < RELEARN_S * 1e9 or self.stale_count < RELEARN_COUNT:
            return Judged(age, old=True)
        self.restart(mono_ns, offset_ns)
        return Judged(0, old=False, relearnt=True, waited_ns=waited, looked_ns=age)


def learn_host(
    hosts: dict[str, OffsetBaseline], host: str, own_host: str, offset_ns: int, mono_ns: int
) -> OffsetBaseline:
    """The baseline of ``host``, started on first sight (offset 0 for ``own_host``)."""
    baseline = hosts.get(host)
    if baseline is None:
        baseline = hosts[host] = OffsetBaseline()
        same = bool(own_host) and host == own_host
        baseline.add(mono_ns, 0 if same else offset_ns)
    return baseline


@dataclass(frozen=True, slots=True)
class CaptureVerdict:
    """How old a message is since capture (seconds; ``None``: not aged), whether it is too old
    to use, and a line worth logging (or empty)."""

    age_s: float | None
    old: bool = False
    note: str = ""


class CaptureAge:
    """Ages messages from their capture, per capture host (see the module doc)."""

    def __init__(self, max_age_s: float, own_host: str = "", what: str = "frame") -> None:
        if not max_age_s > 0:
            raise ValueError("the capture age limit must be positive")
        self.max_age_ns = round(max_age_s * 1e9)
        self.own_host = own_host
        self.what = what
        self._hosts: dict[str, OffsetBaseline] = {}
        #: Messages found too old since capture, in all.
        self.old = 0
        #: Messages not aged (no capture host, or no capture stamp).
        self.unaged = 0
        self._episode = 0
        self._episode_oldest_ns = 0

    def check(
        self, t_capture_ns: int, capture_host: str, wall_ns: int, mono_ns: int
    ) -> CaptureVerdict:
        """The verdict on a message captured at ``t_capture_ns`` on ``capture_host``, seen at
        ``wall_ns`` (this host's wall clock) and ``mono_ns`` (its monotonic clock)."""
        if not capture_host or t_capture_ns <= 0:
            self.unaged += 1  # normal for replays and --fast: nothing to say
            return CaptureVerdict(None)
        offset = wall_ns - t_capture_ns
        baseline = learn_host(self._hosts, capture_host, self.own_host, offset, mono_ns)
        while len(self._hosts) > HOSTS:
            del self._hosts[next(iter(self._hosts))]
        judged = baseline.judge(offset, mono_ns, self.max_age_ns)
        if judged.old:
            self.old += 1
            self._episode += 1
            self._episode_oldest_ns = max(self._episode_oldest_ns, judged.age_ns)
            note = ""
            if self._episode == 1:
                note = (
                    f"{self.what} captured {judged.age_ns / 1e9:.2f} s ago on "
                    f"{capture_host!r} (limit {self.max_age_ns / 1e9:g} s): dropping "
                    f"{self.what}s this old until fresh ones come (an upstream stall?)"
                )
            return CaptureVerdict(judged.age_ns / 1e9, old=True, note=note)
        note = ""
        if self._episode:
            note = (
                f"fresh {self.what}s again: dropped {self._episode} captured up to "
                f"{self._episode_oldest_ns / 1e9:.2f} s before"
            )
            self._episode, self._episode_oldest_ns = 0, 0
        if judged.relearnt:
            note = (
                f"every {self.what} captured on {capture_host!r} looked about "
                f"{judged.looked_ns / 1e9:.2f} s old for "
                f"{judged.waited_ns / 1e9:.1f} s: taking that as its clock offset from now on "
                "(a stepped clock, or a way that stays slower)"
            )
        return CaptureVerdict(judged.age_ns / 1e9, note=note)
