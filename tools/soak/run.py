"""The soak's processes: the rig started, a fault every interval, RSS sampled, the report.

``python -m tools.soak [--hours H] [--interval S] ...`` (``make soak HOURS=H``). The rig is the
fault suite's :class:`Rig` (tests/faults/conftest.py) with the bundled video looped in real time
through the live tracker (``--source replay``: the OpenFace sample replayed, the fault suite's
own, lighter chain). A process that dies without being killed is noted and started again.
Ctrl-C (SIGINT) or SIGTERM ends the soak early, even started in the background with SIGINT
ignored: the fault under way undone, the processes stopped, the report written for the time
it ran (marked ended early; exit code 130 or 143).
"""

from __future__ import annotations

import argparse
import datetime
import os
import re
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path

from facesynth_processes import Processes

from facesynth.runtime.profiles import load_profile
from tools.soak import ROOT, commands, report, rss, schedule
from tools.soak.faults import Injector
from tools.soak.interrupt import EndSignals, Interrupted
from tools.soak.rig import ORDER, Rig

#: Log lines worth a look after a soak: a Python traceback, a C++ or Rust abort.
FINDINGS = re.compile(r"Traceback|FATAL|Fatal Python error|terminate called|panicked|Aborted")


class SoakRig(Rig):
    """The fault rig; with ``source="video"`` the bundled video looped through the tracker."""

    source: str = "video"
    #: With link cuts: each process's Zenoh settings (tools.soak.netns.zenoh_config).
    settings: Callable[[str], list[str]] | None = None

    def args(self, name: str) -> list[str]:
        extra = self.settings(name) if self.settings else []
        if self.source != "video" or name not in ("points", "sensor"):
            return [*super().args(name), *extra]
        common = ["--connect", self.router, "--rig", self.rig, "--stats-interval", "0.5", *extra]
        if name == "points":
            return ["points", "--backend", "tracker", *common]
        waits = "points,features,translator,control"
        return ["sensor", "--source", "video", "--loop", "--wait-for", waits, *common]

    def ready_line(self, name: str) -> str:
        if self.source == "video" and name == "sensor":
            return "sensor: "
        return super().ready_line(name)


def rss_mb(pid: int) -> float | None:
    """VmRSS of ``pid`` in MB; ``None`` once it is gone."""
    try:
        with open(f"/proc/{pid}/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        return None
    return None


class Sampler(threading.Thread):
    """Samples every live process's RSS every ``every`` seconds, per incarnation."""

    def __init__(self, rig: Rig, started_ns: int, every: float) -> None:
        super().__init__(name="rss-sampler", daemon=True)
        self.rig, self.started_ns, self.every = rig, started_ns, every
        self.incarnations: dict[tuple[str, int], rss.Incarnation] = {}
        self.done = threading.Event()

    def sample(self) -> None:
        for name, proc in list(self.rig.live.items()):
            mb = rss_mb(proc.pid)
            if mb is None or proc.poll() is not None:
                continue
            inc = self.incarnations.setdefault((name, proc.pid), rss.Incarnation(name, proc.pid))
            inc.samples.append(rss.Sample((time.time_ns() - self.started_ns) / 1e9, mb))

    def run(self) -> None:
        while not self.done.wait(self.every):
            self.sample()

    def latest(self) -> dict[str, float]:
        return {
            name: inc.samples[-1].mb
            for (name, _), inc in self.incarnations.items()
            if inc.samples and self.rig.live[name].pid == inc.pid
        }

    def by_process(self) -> list[rss.ProcessFigures]:
        return [
            rss.process_figures(name, [i for (n, _), i in self.incarnations.items() if n == name])
            for name in ORDER
        ]


def _tail(rig: Rig, name: str) -> str:
    try:
        return rig.processes.log(rig.log_name(name))[-1500:]
    except OSError:
        return ""


def revive(rig: Rig, died: list[report.Exit]) -> None:
    """Note and start again every process that exited without being killed."""
    for name, proc in list(rig.live.items()):
        if proc.poll() is None:
            continue
        if all(gone.pid != proc.pid for gone in died):  # once, however often it is retried
            tail = _tail(rig, name)
            died.append(report.Exit(name, proc.pid, proc.returncode, time.time_ns(), tail))
            print(f"soak: {name} (pid {proc.pid}) exited with {proc.returncode}; starting it again")
        try:
            rig.start(name)
        except AssertionError as exc:
            print(f"soak: {name} did not start again: {str(exc)[:300]}")


def findings(folder: Path) -> dict[str, list[str]]:
    """Per log file, its lines matching :data:`FINDINGS` (the first 10)."""
    found: dict[str, list[str]] = {}
    for log in sorted(folder.glob("*.log")):
        lines = [
            line for line in log.read_text(errors="replace").splitlines() if FINDINGS.search(line)
        ]
        if lines:
            found[log.stem] = lines[:10]
    return found


def _count_lines(path: Path, state: list[int]) -> int:
    """Newlines of ``path`` so far, read from where the last call stopped (``state``)."""
    if not path.exists():
        return state[1]
    with open(path, "rb") as handle:
        handle.seek(state[0])
        chunk = handle.read()
    state[0] += len(chunk)
    state[1] += chunk.count(b"\n")
    return state[1]


def progress(
    elapsed_s: float, faults: Sequence[schedule.Fault], lines: int, sampler: Sampler, died: int
) -> str:
    kinds: dict[str, int] = {}
    for fault in faults:
        kinds[fault.kind] = kinds.get(fault.kind, 0) + 1
    memory = " ".join(f"{name} {mb:.0f}" for name, mb in sampler.latest().items())
    return (
        f"soak {datetime.timedelta(seconds=round(elapsed_s))}: {len(faults)} faults "
        f"({', '.join(f'{k} {n}' for k, n in kinds.items()) or 'none yet'}); {lines:,} record "
        f"lines; RSS MB {memory}; died on their own {died}"
    )


def parse(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="python -m tools.soak", description=__doc__)
    parser.add_argument("--hours", type=float, default=2.0, help="how long (fractions too)")
    parser.add_argument("--interval", type=float, default=60.0, help="seconds between faults")
    parser.add_argument(
        "--kinds",
        help=f"fault kinds in turn (default {','.join(schedule.KINDS)}, and cut with --link-cuts)",
    )
    parser.add_argument(
        "--link-cuts",
        action="store_true",
        help="C on another network namespace, its link cut 4 s as a fault kind (root)",
    )
    parser.add_argument("--kill", default=",".join(schedule.KILL_TARGETS), help="kill -9 targets")
    parser.add_argument("--source", choices=("video", "replay"), default="video")
    parser.add_argument("--rss-every", type=float, default=5.0, help="RSS sample interval (s)")
    parser.add_argument("--progress-every", type=float, default=300.0, help="progress line (s)")
    parser.add_argument("--out", type=Path, help="report (default runs/soak-<date>.json)")
    parser.add_argument("--folder", type=Path, help="logs and record (default runs/soak-<date>/)")
    args = parser.parse_args(argv)
    if args.hours <= 0 or args.interval <= 0:
        parser.error("--hours and --interval must be positive")
    if args.kinds is None:
        args.kinds = ",".join(schedule.ALL_KINDS if args.link_cuts else schedule.KINDS)
    for kind in args.kinds.split(","):
        if kind not in schedule.ALL_KINDS:
            known = ", ".join(schedule.ALL_KINDS)
            parser.error(f"--kinds: no fault kind {kind!r} (kinds: {known})")
        if kind == "cut" and not args.link_cuts:
            parser.error("--kinds: cut needs --link-cuts")
    if args.link_cuts:
        from tools.soak import netns

        if why := netns.missing():
            parser.error(why)
    for name in args.kill.split(","):
        if name not in ORDER:
            parser.error(f"--kill: no process {name!r} (processes: {', '.join(ORDER)})")
    return args


def main(argv: Sequence[str] | None = None) -> int:
    args = parse(argv)
    stamp = datetime.datetime.now(datetime.UTC).strftime("%Y%m%d-%H%M%S")
    folder = args.folder or ROOT / "runs" / f"soak-{stamp}"
    out = args.out or ROOT / "runs" / f"soak-{stamp}.json"
    folder.mkdir(parents=True, exist_ok=True)
    os.environ["FACESYNTH_STATE"] = str(folder / "state")  # F's learned neutral: the soak's own
    profile = load_profile("paper16")
    hosts = None
    if args.link_cuts:
        from tools.soak import netns

        hosts = netns.Hosts()
        on_hosts = netns.NsProcesses(folder, hosts)
        rig = SoakRig(on_hosts, folder, router=netns.ROUTER)
        rig.settings = netns.zenoh_config
        injector = Injector(rig, hosts=hosts, prefix=on_hosts.on_tracker())
    else:
        rig = SoakRig(Processes(folder), folder)
        injector = Injector(rig)
    rig.source = args.source
    turns = schedule.rounds(args.kinds.split(","), {"kill": args.kill.split(",")})
    faults: list[schedule.Fault] = []
    died: list[report.Exit] = []
    started_ns = time.time_ns()
    sampler = Sampler(rig, started_ns, args.rss_every)
    ending = EndSignals()
    early: Interrupted | None = None
    try:
        ending.install()
        if hosts is not None:
            hosts.create()
        for name in ORDER:
            rig.start(name)
        rig.wait_for_commands(0, 60, timeout=120)
        print(f"soak: the chain streams ({folder}); {args.hours:g} h, a fault every "
              f"{args.interval:g} s", flush=True)  # fmt: skip
        started_ns = sampler.started_ns = time.time_ns()
        t0 = time.monotonic()
        end = t0 + args.hours * 3600
        sampler.sample()
        sampler.start()
        next_fault, next_progress, counted = t0 + args.interval, t0 + args.progress_every, [0, 0]
        while (now := time.monotonic()) < end:
            revive(rig, died)
            if now >= next_fault:
                kind, target = next(turns)
                fault = injector.inject(kind, target)
                faults.append(fault)
                print(f"soak: {kind} {target}: {fault.detail}", flush=True)
                # Behind (a restart under load took long): the next one after a pause.
                next_fault = max(next_fault + args.interval, time.monotonic() + args.interval / 2)
            if now >= next_progress:
                lines = _count_lines(rig.record, counted)
                print(progress(now - t0, faults, lines, sampler, len(died)), flush=True)
                next_progress += args.progress_every
            time.sleep(0.5)
    except Interrupted as signalled:
        early = signalled
        if injector.cut_short is not None:
            faults.append(injector.cut_short)
    finally:
        ending.disarm()  # a second Ctrl-C does not cut the clean-up short
        if undone := injector.undo():
            print(f"soak: the fault under way undone: {', '.join(undone)}", flush=True)
        sampler.done.set()
        ended_ns = time.time_ns()
        rig.processes.stop()
        if hosts is not None:
            hosts.destroy()
    stopped = {name: proc.returncode for name, proc in rig.live.items()}
    lines = rig.lines()
    result = report.SoakResult(
        started_ns=started_ns,
        ended_ns=ended_ns,
        options={k: str(v) if isinstance(v, Path) else v for k, v in vars(args).items()}
        | {"folder": str(folder)},
        faults=faults,
        rss=sampler.by_process(),
        motion=commands.motion(rig.record, profile),
        stale=commands.stale(lines, faults, profile.max_command_age_s),
        gaps=commands.gaps(lines, faults),
        executed=commands.executed(lines),
        died=died,
        stopped=stopped,
        log_findings=findings(folder),
        ended_early=early.signal if early is not None else None,
    )
    print("\n".join(report.summary(result)))
    print(f"soak: report {report.write(result, out)}", flush=True)
    ending.restore()
    return early.exit_code if early is not None else 0
