"""facesynth bench chain: CPU from /proc, hops from an observer, the report, and one real run."""

from __future__ import annotations

import asyncio
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from facesynth.app.bench.chain import (
    ChainFigures,
    ChainVariant,
    bench_chain_once,
    variants,
)
from facesynth.app.bench.chain_report import (
    format_budget,
    format_chain_bench,
    format_summary,
    verdict,
)
from facesynth.app.bench.observe import HOP_NAMES, RigObserver, Trigger
from facesynth.app.bench.processes import CpuWindow, ProcessGroup, cpu_seconds
from facesynth.app.data import sample_openface_csv
from facesynth.runtime import codec, keys
from facesynth.runtime.bus.memory import MemoryNetwork
from facesynth.schemas.messages import ServoCommands

MS = 1_000_000


def test_cpu_seconds_reads_this_process_and_not_a_gone_one() -> None:
    assert (cpu_seconds(os.getpid()) or 0) > 0
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    assert cpu_seconds(proc.pid) is None


def test_cpu_seconds_survives_a_command_name_with_spaces_and_parentheses() -> None:
    code = (
        "import ctypes, time\n"
        "ctypes.CDLL(None).prctl(15, b'a) (b c', 0, 0, 0)\n"  # PR_SET_NAME
        "end = time.process_time() + 0.2\n"
        "while time.process_time() < end: pass\n"
        "print('ready', flush=True); time.sleep(30)\n"
    )
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE)
    try:
        assert proc.stdout is not None and proc.stdout.readline().strip() == b"ready"
        with open(f"/proc/{proc.pid}/stat", encoding="ascii") as handle:
            assert "(a) (b c)" in handle.read()
        assert 0.15 <= (cpu_seconds(proc.pid) or 0) < 5
    finally:
        proc.kill()
        proc.wait()


def test_a_cpu_window_divides_what_a_process_used_by_the_frames() -> None:
    code = "import time\nend = time.process_time() + 0.3\nwhile time.process_time() < end: pass\n"
    proc = subprocess.Popen(
        [sys.executable, "-c", "import sys; sys.stdin.readline()\n" + code], stdin=subprocess.PIPE
    )
    try:
        time.sleep(0.5)  # started, idle
        window = CpuWindow({"burner": proc.pid})
        window.start()
        assert proc.stdin is not None
        proc.stdin.write(b"go\n")
        proc.stdin.flush()
        time.sleep(1.0)
        window.stop()
        assert window.per_frame_ms(10)["burner"] == pytest.approx(30.0, abs=8.0)
        assert window.per_frame_ms(0) == {}
    finally:
        proc.kill()
        proc.wait()


def _observer_with(totals: dict[int, list[float]]) -> RigObserver:
    """An observer whose arrivals say: frame seq took these ms per hop."""
    observer = RigObserver(MemoryNetwork().bus(), "r", hops=True)
    stages = list(HOP_NAMES)
    for stage in stages:
        observer.arrivals[stage] = {}
    for seq, hops in totals.items():
        t = 1_000 * MS + seq * 33 * MS
        observer.captures[seq] = t
        for stage, hop in zip(stages, hops, strict=True):
            t += round(hop * MS)
            observer.arrivals[stage][("", seq)] = t
    return observer


def test_hops_split_capture_to_command_and_the_tail_names_the_hop_that_grew() -> None:
    frames = {seq: [5.0, 1.0, 0.5, 0.2] for seq in range(200)}
    frames[150] = [5.0, 21.0, 0.5, 0.2]  # one late frame, late in features
    frames[151] = [5.0, 19.0, 0.5, 0.2]
    observer = _observer_with(frames)
    hops = observer.hop_latencies(from_seq=60)
    assert [round(float(np.median(v)), 3) for v in hops.values()] == [5.0, 1.0, 0.5, 0.2]
    assert all(len(v) == 140 for v in hops.values())
    tail = observer.tail_hops(from_seq=60, share=0.015)  # the 2 slowest of 140 frames
    assert tail[HOP_NAMES["features"]] == pytest.approx((1.0, 20.0))
    assert tail[HOP_NAMES["points"]] == pytest.approx((5.0, 5.0))


async def test_the_observer_fires_its_triggers_as_the_chain_applies_frames() -> None:
    network = MemoryNetwork()
    fired: list[tuple[str, int]] = []
    observer = RigObserver(
        network.bus(),
        "r",
        triggers=[
            Trigger(3, lambda seq: fired.append(("start", seq))),
            Trigger(6, lambda seq: fired.append(("stop", seq))),
        ],
    )
    observer.start()
    publisher = network.bus()
    for seq in (0, 1, 4, 5, 7, 8):  # frames 2-3 and 6 were lost: fire on the next one
        message = ServoCommands(
            seq=seq, t_capture_ns=1, t_media_ns=1, face=True, profile="p", positions={}
        )
        publisher.publish(keys.stage_key("r", "servo_state", "robot1"), codec.encode(message))
    for _ in range(10):
        await asyncio.sleep(0)
    await observer.close()
    assert fired == [("start", 4), ("stop", 7)]
    assert observer.last_seq == 8


def _figures(variant: ChainVariant, run: int, p50: float, p99: float, cpu: float) -> ChainFigures:
    return ChainFigures(
        variant=variant,
        run=run,
        frames_sent=300,
        commands=300,
        fps=30.0,
        backend="tracker",
        whole_ms=(p50, p99 + 5, p99 + 9),
        steady_ms=(p50, p99, p99 + 2),
        commands_per_s=30.0,
        cpu_ms={"sensor": cpu / 2, "router": cpu / 2},
        machine_busy=0.5,
        others_busy=0.1,
    )


def test_the_report_puts_goals_against_every_runs_figures() -> None:
    assert verdict(7.9, 8.0) == "met"
    assert verdict(9.25, 8.0) == "missed by 1.2 ms"
    assert verdict(float("nan"), 8.0) == "no figure"
    fast, slow = ChainVariant("raw", "fast", mode="peer", sched="realtime"), ChainVariant()
    figures = [
        _figures(fast, 1, 7.5, 11.0, 7.0),
        _figures(slow, 1, 12.0, 20.0, 15.0),
        _figures(fast, 2, 7.9, 21.0, 9.6),
        _figures(slow, 2, 13.0, 22.0, 15.4),
    ]
    summary = format_summary(figures)
    fast_line = next(line for line in summary.splitlines() if "raw fast peer realtime" in line)
    assert "7.5 7.9" in fast_line and "11.0 21.0" in fast_line
    assert "p50 met; p99 missed by 1.0 ms; CPU met" in fast_line  # worst run; mean CPU 8.3
    slow_line = next(line for line in summary.splitlines() if "jpeg full client" in line)
    assert "p50 missed by 3.0 ms" in slow_line and "CPU missed by 5.2 ms" in slow_line
    text = format_chain_bench(figures)
    assert text.count("run 1 ·") == 2 and "whole chain" in text and "router" in text


def test_the_budget_puts_each_process_against_its_share_and_points_beyond_its_model() -> None:
    five, board = ChainVariant(), ChainVariant(layout="board")
    cpu = {"sensor": 1.4, "points": 7.0, "features": 0.6, "translator": 0.3, "control": 0.2}
    figures = [_figures(five, 1, 9.0, 19.0, 0.0), _figures(board, 1, 9.5, 21.0, 0.0)]
    figures[0].cpu_ms = {**cpu, "router": 0.4}
    figures[1].cpu_ms = {"sensor": 1.4, "points": 7.0, "board": 1.25, "router": 0.3}
    text = format_budget(figures, {("full", 1): 5.0})
    rows = {line.split("  ")[2].strip(): line for line in text.splitlines() if "   " in line}
    assert rows["sensor"].endswith("met")
    assert "7.00     6.50   missed by 0.5 ms" in rows["points (model 5.00)"]
    assert "missed by 0.1 ms" in rows["features"] and rows["translator"].endswith("met")
    assert "10.00   met" in rows["five-process chain"]  # 9.9 ms with the router
    assert "1.25     1.00   missed by 0.2 ms" in rows["F + T + C, one process"]
    assert "p50 9.0 ms (met), p99 19.0 ms (met)" in text
    assert "p50 9.5 ms (met), p99 21.0 ms (missed by 1.0 ms)" in text
    assert "jpeg full client board" in text and format_chain_bench(figures).count("CPU budget") == 0


def test_variants_are_every_combination_in_the_order_given() -> None:
    chosen = variants(encodings=("jpeg", "raw"), models=("full", "fast"), scheds=("normal",))
    assert [v.label() for v in chosen] == [
        "jpeg full client",
        "jpeg fast client",
        "raw full client",
        "raw fast client",
    ]
    assert ChainVariant(sched="realtime").router_args() == ["--realtime", "10"]
    boards = variants(layouts=("processes", "board"))
    assert [v.label() for v in boards] == ["jpeg full client", "jpeg full client board"]
    assert boards[0].groups() is None
    assert boards[1].groups() == {"board": ["features", "translator", "control"]}


@pytest.mark.slow
def test_a_real_run_measures_every_process_and_the_router() -> None:
    figures = bench_chain_once(
        ChainVariant(encoding="raw"), seconds=4.0, openface_csv=str(sample_openface_csv())
    )
    # Real time, as the bench plays: on a loaded 2-core machine the latest-only queues and DROP
    # publications let a few frames go by design (measured: 112-120 of 120 with four runs at
    # once); the bench reports how many commands arrived, which is what is checked here.
    assert figures.frames_sent == 120 and 110 <= figures.commands <= 120, figures.commands
    assert set(figures.cpu_ms) == {
        "sensor",
        "points",
        "features",
        "translator",
        "control",
        "router",
    }
    assert all(value > 0 for value in figures.cpu_ms.values()), figures.cpu_ms
    assert 0 < figures.steady_ms[0] <= figures.steady_ms[1] <= figures.steady_ms[2]
    assert set(figures.stage_ms) == {"sensor", "points", "features", "translator", "control"}
    assert set(figures.gc) >= {"sensor", "points", "features", "translator", "control"}
    assert 0 <= figures.others_busy <= figures.machine_busy <= 1


def test_a_baseline_tree_runs_its_own_facesynth_even_from_another_trees_root(
    tmp_path: Path,
) -> None:
    source = tmp_path / "old"
    (source / "facesynth").mkdir(parents=True)
    (source / "facesynth" / "__init__.py").write_text("")
    (source / "facesynth" / "__main__.py").write_text("print('old tree', __file__)\n")
    assert (Path.cwd() / "facesynth" / "__main__.py").is_file()  # run from this tree's root
    group = ProcessGroup(tmp_path, str(source))
    try:
        assert group.start("probe", "--version").wait(timeout=30) == 0
    finally:
        group.close()
    assert f"old tree {source}" in group.log("probe").read_text()


@pytest.mark.slow
def test_a_real_run_with_the_board_as_one_process_measures_it_as_one() -> None:
    figures = bench_chain_once(
        ChainVariant(layout="board"), seconds=3.0, openface_csv=str(sample_openface_csv())
    )
    assert 80 <= figures.commands <= 90, figures.commands
    assert set(figures.cpu_ms) == {"sensor", "points", "board", "router"}
    assert set(figures.stage_ms) == {"sensor", "points", "features", "translator", "control"}
    assert 0 < figures.steady_ms[0] <= figures.steady_ms[1]
