"""How old a message is since its frame was captured, pure: exact on this host's clock,
vouched for on another's.

Every message derived from a frame carries the frame's ``t_capture_ns`` (wall clock of the host
named by ``capture_host``). A receiver ages it by its own wall clock, and what it can vouch for
depends on whose clock stamped it. **The rule:**

* **This host's own clock** (``capture_host`` is the receiver's clock name, which every
  process on its kernel shares: :mod:`facesynth.runtime.clock_host`): the age is exact,
  ``now - t_capture_ns``, from the very first message, and nothing is learnt: a restart of the
  receiver, of an upstream stage or of the sensor changes nothing, and no load, however long,
  can make an old message look young (a baseline learnt from a loaded chain would). A message
  more than ``FUTURE_S`` in the future is refused too (a clock stepped back); when such stamps
  go on for ``RELEARN_S`` they are another clock under this host's name (a camera's own
  stamps), learnt from then on as another host's (below) and said so. After ``RELEARN_S`` of
  nothing but old messages the receiver says once that the chain is too slow here (or that
  another machine, behind, stamps under its name), and still uses none of them.
* **Another host's clock** (offset unknown, never trusted): per host the receiver keeps the
  smallest ``arrival - stamp`` seen (:class:`OffsetBaseline`), which is the offset plus the
  fastest way through, and a message's age is how much later than that it arrived. That is all
  one-way stamps can vouch for: a way that stays slow from the first message on looks young.
  So the baseline never rises faster than a clock can drift (``MAX_DRIFT``, 500 ppm: a loaded
  minute cannot raise it by more than 30 ms) and otherwise follows the smallest offset of the
  last ``WINDOW_S`` (in ``BUCKET_S`` buckets of the receiver's monotonic clock; the newest
  bucket never expires). With a ``probation_s`` (the control interface's), a host first seen
  is *learnt* before any of its messages is used: for ``probation_s`` and at least
  ``PROBATION_COUNT`` messages every message is refused while its offset joins the baseline,
  so a backlog that a stall lets go just as the receiver (re)starts cannot become the
  baseline: the live frames behind it, faster, do. A clock stepped back (or a way that stays
  slower for good) makes every message look old: after ``RELEARN_S`` with nothing else (and
  at least ``RELEARN_COUNT`` of them) the smallest offset of that run becomes the baseline,
  and the verdict says so.

A verdict also says until when (the receiver's wall clock) the message stays within the limit
(:attr:`CaptureVerdict.deadline_ns`), so a receiver that acts on it later can judge it again
at the last moment (the control interface does, just before its driver writes).

:class:`CaptureAge` applies this to capture stamps, with the episodes a log needs: the first
old message of a run says so once, the first fresh one after it says how many were dropped.
Messages without a capture host (older senders, replays of recordings, ``--fast`` sensors whose
frames wait for credit by design) are not aged. The controller ages its senders' ``sent_ns``
with the same :class:`OffsetBaseline` (:mod:`facesynth.services.control.freshness`). Time is
data: the caller passes its wall and monotonic clocks' readings in nanoseconds.
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
#: The fastest a baseline may rise: a clock drifting at most this fast (500 ppm).
MAX_DRIFT = 500e-6
#: A stamp of the receiver's own clock this far in the future (seconds) is refused.
FUTURE_S = 0.05
#: A probation lasts at least this many messages (besides its ``probation_s``).
PROBATION_COUNT = 10
#: The control interface's probation of a capture host first seen (seconds).
PROBATION_S = 1.0
#: The default capture age limit of the stages that know no profile (points, features: their
#: node option ``max_input_age_s``): the profiles' default ``max_command_age_s``.
DEFAULT_MAX_AGE_S = 0.25
#: How many capture hosts are remembered.
HOSTS = 64


@dataclass(frozen=True, slots=True)
class Judged:
    """An offset judged against a baseline: the age (ns, at least 0), whether it is over the
    limit, and whether the baseline was just re-learnt from it (a stepped clock).

    ``why`` says why an old one is refused when its age is not the reason: ``"future"`` (own
    clock, stamped ahead) or ``"learning"`` (the host's probation); ``"not-own"`` with
    ``relearnt``: the own host's name stamped by another clock, learnt from now on.
    ``baseline_ns`` is the baseline it was judged against (0 on the receiver's own clock)."""

    age_ns: int
    old: bool
    relearnt: bool = False
    #: For a re-learnt baseline (or the own clock's run of old ones): how long, and how old,
    #: everything looked.
    waited_ns: int = 0
    looked_ns: int = 0
    why: str = ""
    baseline_ns: int = 0
    #: The own clock's run of old messages just reached ``RELEARN_S`` (said once per run).
    slow: bool = False


@dataclass
class OffsetBaseline:
    """The offset baseline of one host (see the module doc), and its run of old messages.

    ``exact``: the receiver's own clock (offset 0, nothing learnt). ``learning_until_ns``: the
    end (monotonic) of a probation under way, ``None`` when there is none."""

    buckets: collections.deque[list[int]] = field(default_factory=collections.deque)
    stale_since_ns: int | None = None
    stale_count: int = 0
    exact: bool = False
    #: The smallest offset of the current run of old messages (what a re-learn takes).
    stale_lowest_ns: int | None = None
    #: ``offset - MAX_DRIFT * mono`` at its smallest: the drift bound's anchor (ns).
    anchor: int | None = None
    learning_until_ns: int | None = None
    learning_count: int = 0
    #: The own clock's run of old messages was said to be too slow.
    slow_said: bool = False
    #: The own clock's run of stamps from the future: since when, how many, the smallest.
    future_since_ns: int | None = None
    future_count: int = 0
    future_lowest_ns: int = 0

    def baseline(self, mono_ns: int | None = None) -> int:
        """The baseline (ns): the smallest offset in the window, no higher than the smallest
        offset ever seen plus what a clock can have drifted since (at ``mono_ns``)."""
        if self.exact:
            return 0
        window = min(offset for _, offset in self.buckets)
        if mono_ns is None or self.anchor is None:
            return window
        return min(window, self.anchor + round(MAX_DRIFT * mono_ns))

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
        anchor = offset_ns - round(MAX_DRIFT * mono_ns)
        self.anchor = anchor if self.anchor is None else min(self.anchor, anchor)

    def restart(self, mono_ns: int, offset_ns: int) -> None:
        """Forget the window: ``offset_ns`` is the baseline from now on."""
        self.buckets = collections.deque()
        self.anchor = None
        self.add(mono_ns, offset_ns)
        self.stale_since_ns, self.stale_count, self.stale_lowest_ns = None, 0, None

    def learn(self, mono_ns: int, offset_ns: int, probation_s: float) -> None:
        """A host first seen: its baseline starts from ``offset_ns``, on probation for
        ``probation_s`` (none when 0)."""
        self.add(mono_ns, offset_ns)
        if probation_s > 0:
            self.learning_until_ns = mono_ns + round(probation_s * 1e9)

    def judge(self, offset_ns: int, mono_ns: int, max_age_ns: int) -> Judged:
        """Age ``offset_ns`` (seen at ``mono_ns``) and learn from it: an old one only counts
        toward a re-learnt baseline, a fresh one joins the window."""
        if self.exact:
            return self._judge_exact(offset_ns, mono_ns, max_age_ns)
        if self.learning_until_ns is not None:
            self.learning_count += 1
            self.add(mono_ns, offset_ns)
            if mono_ns < self.learning_until_ns or self.learning_count < PROBATION_COUNT:
                return Judged(0, old=True, why="learning", baseline_ns=self.baseline(mono_ns))
            self.learning_until_ns, self.learning_count = None, 0
        baseline = self.baseline(mono_ns)
        age = offset_ns - baseline
        if age <= max_age_ns:
            self.stale_since_ns, self.stale_count, self.stale_lowest_ns = None, 0, None
            self.add(mono_ns, offset_ns)
            return Judged(max(age, 0), old=False, baseline_ns=baseline)
        self._count_stale(offset_ns, mono_ns)
        waited = mono_ns - (self.stale_since_ns or mono_ns)
        if waited < RELEARN_S * 1e9 or self.stale_count < RELEARN_COUNT:
            return Judged(age, old=True, baseline_ns=baseline)
        lowest = self.stale_lowest_ns if self.stale_lowest_ns is not None else offset_ns
        self.restart(mono_ns, lowest)
        age = offset_ns - lowest
        return Judged(
            age,
            old=age > max_age_ns,
            relearnt=True,
            waited_ns=waited,
            looked_ns=offset_ns - baseline,
            baseline_ns=lowest,
        )

    def _judge_exact(self, offset_ns: int, mono_ns: int, max_age_ns: int) -> Judged:
        if offset_ns < -round(FUTURE_S * 1e9):
            return self._from_the_future(offset_ns, mono_ns, max_age_ns)
        self.future_since_ns, self.future_count = None, 0
        if offset_ns <= max_age_ns:
            self.stale_since_ns, self.stale_count, self.stale_lowest_ns = None, 0, None
            self.slow_said = False
            return Judged(max(offset_ns, 0), old=False)
        self._count_stale(offset_ns, mono_ns)
        waited = mono_ns - (self.stale_since_ns or mono_ns)
        slow = waited >= RELEARN_S * 1e9 and self.stale_count >= RELEARN_COUNT
        said, self.slow_said = self.slow_said, self.slow_said or slow
        return Judged(
            offset_ns, old=True, slow=slow and not said, waited_ns=waited, looked_ns=offset_ns
        )

    def _from_the_future(self, offset_ns: int, mono_ns: int, max_age_ns: int) -> Judged:
        """A stamp of the own host from the future: refused; when they have come for
        ``RELEARN_S`` (and ``RELEARN_COUNT``), this is not the receiver's clock after all (a
        camera's own stamps under this host's name): it is learnt from then on as another
        host's, from the fastest of that run, and the verdict says so."""
        if self.future_since_ns is None:
            self.future_since_ns, self.future_count = mono_ns, 0
            self.future_lowest_ns = offset_ns
        self.future_count += 1
        self.future_lowest_ns = min(self.future_lowest_ns, offset_ns)
        waited = mono_ns - self.future_since_ns
        if waited < RELEARN_S * 1e9 or self.future_count < RELEARN_COUNT:
            return Judged(offset_ns, old=True, why="future")
        self.exact = False
        self.restart(mono_ns, self.future_lowest_ns)
        age = offset_ns - self.future_lowest_ns
        return Judged(
            age,
            old=age > max_age_ns,
            relearnt=True,
            waited_ns=waited,
            looked_ns=offset_ns,
            why="not-own",
            baseline_ns=self.future_lowest_ns,
        )

    def _count_stale(self, offset_ns: int, mono_ns: int) -> None:
        if self.stale_since_ns is None:
            self.stale_since_ns = mono_ns
        self.stale_count += 1
        lowest = self.stale_lowest_ns
        self.stale_lowest_ns = offset_ns if lowest is None else min(lowest, offset_ns)


def learn_host(
    hosts: dict[str, OffsetBaseline],
    host: str,
    own_host: str,
    offset_ns: int,
    mono_ns: int,
    probation_s: float = 0.0,
) -> OffsetBaseline:
    """The baseline of ``host``, started on first sight: exact for ``own_host``, else learnt
    from ``offset_ns`` (on probation for ``probation_s``, when given)."""
    baseline = hosts.get(host)
    if baseline is None:
        if own_host and host == own_host:
            baseline = hosts[host] = OffsetBaseline(exact=True)
        else:
            baseline = hosts[host] = OffsetBaseline()
            baseline.learn(mono_ns, offset_ns, probation_s)
    return baseline


@dataclass(frozen=True, slots=True)
class CaptureVerdict:
    """How old a message is since capture (seconds; ``None``: not aged), whether it is too old
    to use, a line worth logging (or empty), and until when (the receiver's wall clock, ns) it
    stays within the limit (``None``: not aged)."""

    age_s: float | None
    old: bool = False
    note: str = ""
    deadline_ns: int | None = None


class CaptureAge:
    """Ages messages from their capture, per capture host (see the module doc); a host first
    seen (not the receiver's own) is on probation for ``probation_s``, 0 for none."""

    def __init__(
        self, max_age_s: float, own_host: str = "", what: str = "frame", probation_s: float = 0.0
    ) -> None:
        if not max_age_s > 0:
            raise ValueError("the capture age limit must be positive")
        if probation_s < 0:
            raise ValueError("the probation of a capture host cannot be negative")
        self.max_age_ns = round(max_age_s * 1e9)
        self.own_host = own_host
        self.what = what
        self.probation_s = probation_s
        self._hosts: dict[str, OffsetBaseline] = {}
        #: Messages found too old since capture, in all.
        self.old = 0
        #: Messages not used while their capture host's clock was learnt (its probation).
        self.held = 0
        self._held_run = 0
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
        baseline = learn_host(
            self._hosts, capture_host, self.own_host, offset, mono_ns, self.probation_s
        )
        while len(self._hosts) > HOSTS:
            del self._hosts[next(iter(self._hosts))]
        judged = baseline.judge(offset, mono_ns, self.max_age_ns)
        if judged.old:
            return self._old(judged, capture_host)
        note = ""
        if self._held_run:
            note = (
                f"the clock of {capture_host!r} is learnt: {self.what}s captured there are "
                f"used from now on ({self._held_run} not used while it was learnt)"
            )
            self._held_run = 0
        if self._episode:
            note = (
                f"fresh {self.what}s again: dropped {self._episode} captured up to "
                f"{self._episode_oldest_ns / 1e9:.2f} s before"
            )
            self._episode, self._episode_oldest_ns = 0, 0
        if judged.relearnt:
            note = self._relearnt(judged, capture_host)
        deadline = t_capture_ns + judged.baseline_ns + self.max_age_ns
        return CaptureVerdict(judged.age_ns / 1e9, note=note, deadline_ns=deadline)

    def _old(self, judged: Judged, capture_host: str) -> CaptureVerdict:
        """The verdict on a message refused: counted, and said once per run of them."""
        if judged.why == "learning":
            self.held += 1
            self._held_run += 1
            note = ""
            if self._held_run == 1:
                note = (
                    f"{self.what}s captured on {capture_host!r}, a clock not yet learnt: none "
                    f"is used for its first {self.probation_s:g} s and {PROBATION_COUNT} "
                    f"{self.what}s, until their age can be vouched for"
                )
            return CaptureVerdict(None, old=True, note=note)
        self.old += 1
        self._episode += 1
        self._episode_oldest_ns = max(self._episode_oldest_ns, judged.age_ns)
        limit = f"(limit {self.max_age_ns / 1e9:g} s)"
        note = ""
        if judged.relearnt:
            note = self._relearnt(judged, capture_host)
        elif judged.why == "future" and self._episode == 1:
            note = (
                f"{self.what} captured {-judged.age_ns / 1e9:.2f} s in the future by this "
                f"host's own clock ({capture_host!r}): dropping such {self.what}s (a clock "
                "stepped back, or another machine stamping under this host's name?)"
            )
        elif judged.slow:
            note = (
                f"every {self.what} captured on this host ({capture_host!r}) has been over "
                f"the limit for {judged.waited_ns / 1e9:.1f} s, about "
                f"{judged.looked_ns / 1e9:.2f} s old {limit}: the chain is too slow here "
                "(or another machine stamps under this host's name); none is used"
            )
        elif self._episode == 1:
            note = (
                f"{self.what} captured {judged.age_ns / 1e9:.2f} s ago on "
                f"{capture_host!r} {limit}: dropping "
                f"{self.what}s this old until fresh ones come (an upstream stall?)"
            )
        return CaptureVerdict(judged.age_ns / 1e9, old=True, note=note)

    def _relearnt(self, judged: Judged, capture_host: str) -> str:
        if judged.why == "not-own":
            return (
                f"every {self.what} stamped on this host's name ({capture_host!r}) came "
                f"{-judged.looked_ns / 1e9:.2f} s from the future for "
                f"{judged.waited_ns / 1e9:.1f} s: not this host's clock after all (a camera's "
                "own stamps?); learning it as another host's from now on"
            )
        return (
            f"every {self.what} captured on {capture_host!r} looked about "
            f"{judged.looked_ns / 1e9:.2f} s old for {judged.waited_ns / 1e9:.1f} s: taking "
            "the fastest of them as its clock offset from now on (a stepped clock, or a way "
            "that stays slower)"
        )
