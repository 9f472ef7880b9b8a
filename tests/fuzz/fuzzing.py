"""The fuzz suite's settings and its tally: cases and outcomes per target, printed at the end
(by ``conftest.py``).

Every target runs ``CASES`` (10,000) hypothesis cases, derandomized (the same cases on every
run, so a failure in CI reproduces here) and without an example database. Each case goes
through :func:`outcome`: a valid result, or one of the target's documented errors (a
``ValueError`` subclass with a one-line message) counted as refused; anything else fails the
test. ``FACESYNTH_FUZZ_CASES`` lowers the count while iterating on a target (never in CI).
"""

from __future__ import annotations

import atexit
import collections
import contextlib
import os
import shutil
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypeVar

import pytest
from hypothesis import HealthCheck, settings

#: Hypothesis cases per target.
CASES = int(os.environ.get("FACESYNTH_FUZZ_CASES", "10000"))
#: No case may take this much CPU (seconds of this thread's time, not wall time, so a loaded
#: machine's preemption does not count): a parser that loops on some input is a failure too.
SLOWEST_CASE_S = 2.0
#: Each fuzz test's wall-clock limit, a guard against a hang only (each case's CPU is bounded by
#: SLOWEST_CASE_S above; a test takes 10-150 s of CPU): CI runs the suite at the idle
#: scheduling class beside the other groups (.ci/run), where it can wait minutes for a core.
TIMEOUT = pytest.mark.timeout(1800)

FUZZ = settings(
    max_examples=CASES,
    deadline=None,
    derandomize=True,
    database=None,
    print_blob=True,
    suppress_health_check=[
        HealthCheck.too_slow,
        HealthCheck.data_too_large,
        HealthCheck.filter_too_much,
        HealthCheck.large_base_example,
        HealthCheck.function_scoped_fixture,
    ],
)

T = TypeVar("T")


@dataclass
class Tally:
    """What happened to one target's cases."""

    target: str
    counts: collections.Counter[str] = field(default_factory=collections.Counter)
    slowest_s: float = 0.0

    @property
    def cases(self) -> int:
        return sum(self.counts.values())

    def count(self, kind: str) -> None:
        self.counts[kind] += 1

    def line(self) -> str:
        parts = ", ".join(f"{kind} {n}" for kind, n in sorted(self.counts.items()))
        return (
            f"{self.target:<44} {self.cases:>6} cases: {parts} "
            f"(slowest {self.slowest_s * 1e3:.1f} ms CPU)"
        )


TALLIES: dict[str, Tally] = {}


def tally(target: str) -> Tally:
    """The tally of ``target`` (made on first use)."""
    return TALLIES.setdefault(target, Tally(target))


def outcome(
    target: str,
    call: Callable[[], T],
    errors: type[BaseException] | tuple[type[BaseException], ...],
) -> T | None:
    """``call()``'s result (counted ``valid``), or ``None`` when it raised one of ``errors``
    with a one-line message (counted ``refused``); any other exception propagates."""
    record = tally(target)
    started = time.thread_time()
    try:
        result = call()
    except errors as exc:
        message = str(exc)
        assert message and "\n" not in message, f"{type(exc).__name__} message: {message!r}"
        record.count("refused")
        return None
    finally:
        elapsed = time.thread_time() - started
        record.slowest_s = max(record.slowest_s, elapsed)
        assert elapsed < SLOWEST_CASE_S, f"{target}: one case took {elapsed:.2f} s"
    record.count("valid")
    return result


def check_tally(target: str, *kinds: str, every_case: bool = True) -> None:
    """After a target ran: every case was counted (unless the target sees only some cases, as
    a core behind a decoder does), and each of ``kinds`` happened (a target whose cases are all
    refused, or all valid, is not exploring what it should)."""
    record = TALLIES[target]
    if every_case:
        assert record.cases >= CASES, f"{target}: {record.cases} cases counted, {CASES} expected"
    for kind in kinds:
        assert record.counts[kind] > 0, f"{target}: no {kind} case in {record.line()}"


@contextlib.contextmanager
def libjpeg_quiet() -> Iterator[None]:
    """Standard error (fd 2) to /dev/null: libjpeg prints a line per corrupt JPEG it reads."""
    sys.stderr.flush()
    saved = os.dup(2)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(devnull)


#: Memory-backed scratch space when the machine has it (Linux's /dev/shm).
SHM = Path("/dev/shm")


def scratch_folder(prefix: str) -> Path:
    """A new folder for the files targets read their cases from, in memory (``/dev/shm``) when
    there is one: each case rewrites its file, and on a disk (ext4 flushes a truncated file's
    data when it is closed) each rewrite took about 3 ms, more than the case itself."""
    memory = SHM.is_dir() and os.access(SHM, os.W_OK)
    folder = Path(tempfile.mkdtemp(prefix=prefix, dir=SHM if memory else None))
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    return folder
