"""Injecting the soak's faults into a running rig (the shell; what comes next is
:mod:`tools.soak.schedule`'s).

Each injection returns the :class:`~tools.soak.schedule.Fault` it made, with its wall-clock
start and end. The flood and the oversized burst are the fault suite's own publishers
(tests/faults/flooder.py, tests/faults/big_sender.py), run as processes against the rig's
router. A soak ended in the middle of a fault (:mod:`tools.soak.interrupt`) calls
:meth:`Injector.undo`: the stalled process continued, the cut link up again.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from typing import Any

from facesynth.runtime import keys
from tools.soak import FAULTS
from tools.soak.rig import Rig
from tools.soak.schedule import Fault

FLOODER = FAULTS / "flooder.py"
BIG_SENDER = FAULTS / "big_sender.py"


@dataclass
class Injector:
    """Injects faults into ``rig``: how long a stall and a flood last, how fast a flood
    publishes, how many messages an oversized burst sends."""

    rig: Rig
    stall_s: float = 3.0
    flood_s: float = 4.0
    flood_rate: int = 10_000
    burst: int = 3
    #: How long a killed process stays dead before it is started again (s).
    dead_s: float = 1.0
    #: How long the board's link stays cut (s), and the hosts (tools.soak.netns; link cuts only).
    cut_s: float = 4.0
    hosts: Any = None
    #: What runs the flooder and the big-message sender where the router is (``ip netns exec``).
    prefix: tuple[str, ...] = ()
    #: The fault an exception (the soak ending early) cut short, ending when it was cut.
    cut_short: Fault | None = field(default=None, init=False)
    #: A process stopped by a stall not yet continued; the link of a cut not yet up again.
    _stopped: subprocess.Popen[bytes] | None = field(default=None, init=False, repr=False)
    _link_down: bool = field(default=False, init=False, repr=False)

    def inject(self, kind: str, target: str) -> Fault:
        start = time.time_ns()
        try:
            detail = {
                "kill": self.kill,
                "stall": self.stall,
                "flood": self.flood,
                "oversized": self.oversized,
                "cut": self.cut,
            }[kind](target)
        except BaseException as exc:
            why = type(exc).__name__ + (f" {exc}" if str(exc) else "")
            self.cut_short = Fault(kind, target, start, time.time_ns(), f"cut short: {why}")
            raise
        return Fault(kind, target, start, time.time_ns(), detail)

    def undo(self) -> list[str]:
        """Put back what a fault cut short left: the stalled process continued, the board's
        link up; what it did (nothing when no fault was under way)."""
        done = []
        if self._stopped is not None:
            if self._stopped.poll() is None:
                self._stopped.send_signal(signal.SIGCONT)
                done.append(f"pid {self._stopped.pid} continued")
            self._stopped = None
        if self._link_down:
            self.hosts.link_up()
            self._link_down = False
            done.append("board link up")
        return done

    def kill(self, name: str) -> str:
        """SIGKILL ``name``, wait ``dead_s``, start it again and wait until it is ready."""
        pid = self.rig.live[name].pid
        self.rig.kill(name)
        time.sleep(self.dead_s)
        self.rig.start(name)
        return f"pid {pid} killed, pid {self.rig.live[name].pid} ready"

    def stall(self, name: str) -> str:
        """SIGSTOP ``name`` for ``stall_s``, then SIGCONT (cut short: :meth:`undo`)."""
        proc = self.rig.live[name]
        self._stopped = proc  # before the signal: undone however early the soak ends
        proc.send_signal(signal.SIGSTOP)
        time.sleep(self.stall_s)
        proc.send_signal(signal.SIGCONT)
        self._stopped = None
        return f"pid {proc.pid} stopped {self.stall_s:g} s"

    def _key(self, stage: str) -> str:
        if stage == "stats":
            return keys.stats_key(self.rig.rig, "translator", "flooder")
        return keys.stage_key(self.rig.rig, stage)  # type: ignore[arg-type]

    def flood(self, stage: str) -> str:
        """The flooder on ``stage``'s key for ``flood_s`` at ``flood_rate`` messages a second."""
        args = [self.rig.router, self._key(stage), stage, str(self.flood_s), "100000000"]
        done = subprocess.run(
            [*self.prefix, sys.executable, str(FLOODER), *args, str(self.flood_rate)],
            capture_output=True,
            text=True,
            timeout=self.flood_s + 60,
        )
        if done.returncode != 0:
            return f"flooder exit {done.returncode}: {done.stderr.strip()[-300:]}"
        sent = json.loads(done.stdout.strip().splitlines()[-1])["sent"]
        return f"{sent} messages in {self.flood_s:g} s"

    def oversized(self, target: str) -> str:
        """``burst`` oversized messages (``KEY:KIND``, big_sender's kinds), 0.1 s apart."""
        stage, kind = target.split(":")
        args = [self.rig.router, self._key(stage), kind, str(self.burst), "0.1"]
        done = subprocess.run(
            [*self.prefix, sys.executable, str(BIG_SENDER), *args],
            capture_output=True,
            text=True,
            timeout=120,
        )
        if done.returncode != 0:
            return f"big_sender exit {done.returncode}: {done.stderr.strip()[-300:]}"
        size = int(done.stdout.split()[1])
        return f"{self.burst} x {size / 1e6:.1f} MB"

    def cut(self, target: str) -> str:
        """Take the board's link down for ``cut_s``, then up again (cut short: :meth:`undo`)."""
        if self.hosts is None:
            raise ValueError("a link cut needs the hosts of --link-cuts")
        self._link_down = True  # before the cut: undone however early the soak ends
        self.hosts.link_down()
        time.sleep(self.cut_s)
        self.hosts.link_up()
        self._link_down = False
        return f"{target} link down {self.cut_s:g} s"
