"""facesynth.app.tuning: scheduling requests applied to real processes, and buffer reuse."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from collections.abc import Iterator

import pytest

from facesynth.app.tuning import (
    Scheduling,
    SchedulingError,
    apply_scheduling,
    combined,
    keep_buffers,
)


@pytest.fixture
def child() -> Iterator[subprocess.Popen[bytes]]:
    """A sleeping child process to apply scheduling to (this test process stays untouched)."""
    proc = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    yield proc
    proc.kill()
    proc.wait()


def test_nothing_requested_by_default() -> None:
    assert not Scheduling().requested
    assert Scheduling().describe() == "default scheduling"


def test_one_process_for_several_nodes_takes_the_most_demanding_of_each() -> None:
    request = combined(
        [Scheduling(nice=5), Scheduling(nice=-3, cpus=(1,)), Scheduling(realtime=10, cpus=(0,))]
    )
    assert request == Scheduling(nice=-3, realtime=10, cpus=(0, 1))
    assert combined([Scheduling(), Scheduling()]) == Scheduling()


def test_nice_and_cores_are_applied(child: subprocess.Popen[bytes]) -> None:
    core = min(os.sched_getaffinity(0))
    apply_scheduling(Scheduling(nice=7, cpus=(core,)), child.pid)
    assert os.getpriority(os.PRIO_PROCESS, child.pid) == 7
    assert os.sched_getaffinity(child.pid) == {core}


def test_realtime_is_applied_where_permitted(child: subprocess.Popen[bytes]) -> None:
    if os.geteuid() != 0 and os.sched_get_priority_max(os.SCHED_FIFO) > 0:
        # An ordinary user (CI runs as root): refused with the reason, nothing changed.
        with pytest.raises(SchedulingError, match="not permitted"):
            apply_scheduling(Scheduling(realtime=3), child.pid)
        assert os.sched_getscheduler(child.pid) == os.SCHED_OTHER
        return
    apply_scheduling(Scheduling(realtime=3), child.pid)
    assert os.sched_getscheduler(child.pid) == os.SCHED_FIFO
    assert os.sched_getparam(child.pid).sched_priority == 3


@pytest.mark.parametrize(
    ("request_", "message"),
    [
        (Scheduling(cpus=(4096,)), "no core 4096 here"),
        (Scheduling(nice=25), "must be within -20..19"),
        (Scheduling(realtime=0), "must be within 1..99"),
        (Scheduling(realtime=100), "must be within 1..99"),
    ],
    ids=["unknown-core", "nice-range", "realtime-zero", "realtime-range"],
)
def test_impossible_requests_are_one_line_errors(
    child: subprocess.Popen[bytes], request_: Scheduling, message: str
) -> None:
    with pytest.raises(SchedulingError, match=message) as info:
        apply_scheduling(request_, child.pid)
    assert "\n" not in str(info.value)


def test_without_the_privilege_the_error_says_what_is_needed() -> None:
    # A process without CAP_SYS_NICE, as an ordinary user runs facesynth (root here drops it
    # from its bounding set with util-linux's setpriv; RLIMIT_RTPRIO and RLIMIT_NICE are 0).
    code = (
        "from facesynth.app.tuning import Scheduling, SchedulingError, apply_scheduling\n"
        "for request in (Scheduling(realtime=5), Scheduling(nice=-5)):\n"
        "    try:\n"
        "        apply_scheduling(request)\n"
        "    except SchedulingError as exc:\n"
        "        print(exc)\n"
    )
    prefix: list[str] = []
    if os.geteuid() == 0:
        setpriv = shutil.which("setpriv")
        assert setpriv, "this test needs util-linux's setpriv to drop CAP_SYS_NICE as root"
        prefix = [setpriv, "--bounding-set", "-sys_nice"]
    out = subprocess.run(
        [*prefix, sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=30,
        check=True,
        env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)},
    ).stdout.splitlines()
    assert len(out) == 2, out
    assert out[0].startswith("--realtime 5: not permitted") and "CAP_SYS_NICE" in out[0]
    assert out[1].startswith("--nice -5: not permitted") and "ulimit -e" in out[1]


def test_buffers_are_kept_on_glibc() -> None:
    # Linux with glibc here (Debian); elsewhere keep_buffers is a no-op returning False.
    assert keep_buffers() is True
