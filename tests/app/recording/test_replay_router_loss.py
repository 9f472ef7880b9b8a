"""`facesynth replay` whose router is killed mid-replay: it counts only what was published while
linked, and exits 2 with one line instead of reporting success."""

from __future__ import annotations

import asyncio
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from facesynth_processes import Processes, free_port

from facesynth.app.recording.convert import landmarks_to_mcap
from facesynth.app.recording.replay import ReplayLinkTally
from facesynth.runtime import keys
from facesynth.runtime.bus.link import LinkFigures
from facesynth.runtime.bus.zenoh_bus import ZenohBus, ZenohOptions

OPENFACE = Path(__file__).parents[3] / "facesynth" / "app" / "data" / "OpenFace_Test.csv"


def _replay(session: Path, router: str, rig: str, log: Path) -> subprocess.Popen[str]:
    argv = [sys.executable, "-m", "facesynth", "replay", str(session), "--from", "points"]
    argv += ["--speed", "0.5", "--connect", router, "--rig", rig]
    with open(log, "w") as handle:  # the process keeps its own copy of the file
        return subprocess.Popen(
            argv,
            stdout=subprocess.PIPE,
            stderr=handle,
            text=True,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )


def _wait_for(path: Path, text: str, timeout: float = 30.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if text in path.read_text(errors="replace"):
            return
        time.sleep(0.05)
    raise AssertionError(f"never logged {text!r}:\n{path.read_text(errors='replace')}")


async def test_a_replay_whose_router_is_killed_exits_2_and_counts_what_was_delivered(
    processes: Processes, tmp_path: Path, rig: str
) -> None:
    session = tmp_path / "points.mcap"
    total = landmarks_to_mcap(OPENFACE, session, rig=rig)  # 99 frames: 6.6 s at --speed 0.5
    router = f"tcp/127.0.0.1:{free_port()}"
    server = processes.start("router", "--listen", router, name="router")
    processes.wait_for_line("router", "listening")
    listener = ZenohBus.open(ZenohOptions(mode="client", connect=[router]))
    heard = listener.subscribe_queued(keys.stage_key(rig, "points"), 1024)
    log = tmp_path / "replay.log"
    replay = _replay(session, router, rig, log)
    try:
        await asyncio.to_thread(_wait_for, log, "replaying points")
        await asyncio.sleep(1.5)
        server.send_signal(signal.SIGKILL)
        await asyncio.to_thread(server.wait, 10)
        out, _ = await asyncio.to_thread(replay.communicate, None, 60)
    finally:
        if replay.poll() is None:
            replay.kill()
            replay.wait()
    received = 0
    while heard.receive_nowait() is not None:
        received += 1
    await listener.close()
    stderr = log.read_text()
    assert replay.returncode == 2, stderr
    last = stderr.strip().splitlines()[-1]
    assert last.startswith("facesynth replay: error: lost the Zenoh router "), stderr
    assert "Traceback" not in stderr
    summary = json.loads(out)
    assert summary["router_losses"] == 1
    published, unsent = summary["published"], summary["sent_without_router"]
    assert published + unsent == total, summary
    assert 0 < received <= published < total, (received, summary)
    assert unsent > total // 2, summary  # killed 1.5 s into 6.6 s
    assert f"{published} of {total} messages were published while linked" in last
    assert f"{unsent} with no router reached nobody" in last


def test_a_replay_whose_router_stays_publishes_everything_and_exits_0(
    processes: Processes, tmp_path: Path, rig: str
) -> None:
    session = tmp_path / "points.mcap"
    total = landmarks_to_mcap(OPENFACE, session, rig=rig)
    router = f"tcp/127.0.0.1:{free_port()}"
    processes.start("router", "--listen", router, name="router")
    processes.wait_for_line("router", "listening")
    argv = [sys.executable, "-m", "facesynth", "replay", str(session), "--speed", "20"]
    result = subprocess.run(
        [*argv, "--connect", router, "--rig", rig], capture_output=True, text=True, timeout=60
    )
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout)
    assert summary["published"] == total and "sent_without_router" not in summary


def _link(connected: bool, losses: int, down_for_s: float = 0.0) -> LinkFigures:
    return LinkFigures(
        connected=connected, losses=losses, offline_s=down_for_s, down_for_s=down_for_s
    )


def test_the_tally_counts_messages_published_with_no_router_as_lost() -> None:
    tally = ReplayLinkTally()
    tally.start(_link(True, 0))
    assert tally.published(_link(True, 0), 0.1)
    assert not tally.published(_link(False, 1, 0.2), 1.6)
    assert not tally.published(_link(False, 1, 0.3), 1.7)
    assert tally.published(_link(True, 1), 2.0)  # regained: delivered again, still a loss
    assert (tally.delivered, tally.unlinked, tally.losses) == (2, 2, 1)
    assert tally.lost_at_s is not None and abs(tally.lost_at_s - 1.4) < 1e-9
    problem = tally.problem(4)
    assert problem is not None
    assert problem.startswith("lost the Zenoh router 1.4 s into the replay: 2 of 4 messages")


def test_the_tally_sees_a_loss_between_messages_and_ignores_earlier_ones() -> None:
    tally = ReplayLinkTally()
    tally.start(_link(True, 3))  # lost before this replay: not its problem
    assert tally.published(_link(True, 3), 0.0)
    assert tally.problem(1) is None
    tally.observe(_link(True, 4), 5.0)  # lost and regained while nothing was sent
    assert tally.losses == 1 and tally.unlinked == 0
    assert tally.problem(1) is not None


def test_a_session_with_no_router_to_lose_delivers_everything() -> None:
    tally = ReplayLinkTally()
    tally.start(None)  # a router's own session, or the in-memory bus
    assert tally.published(None, 0.0)
    tally = ReplayLinkTally()
    tally.start(_link(False, 0))  # a peer that never had a router
    assert tally.published(_link(False, 0), 0.0)
    assert tally.problem(1) is None and tally.delivered == 1
