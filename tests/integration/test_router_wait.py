"""A service started before its router waits for it (saying so once) and then works; with
``--router-timeout`` it gives up with one clear line."""

from __future__ import annotations

import time
from pathlib import Path

from facesynth_processes import Processes, free_port, run_facesynth

from facesynth.app.data import sample_openface_csv
from facesynth.services.control.drivers.record import read_record


def test_a_service_started_before_its_router_waits_says_so_once_then_works(
    spawn: Processes, tmp_path: Path
) -> None:
    router = f"tcp/127.0.0.1:{free_port()}"
    common = ["--connect", router, "--rig", "waits"]
    out = tmp_path / "commands.jsonl"
    spawn("control", "--out", str(out), "--motion-time", "media", *common, name="control")
    spawn("translator", *common, name="translator")
    spawn("features", *common, name="features")
    spawn("points", "--openface-csv", str(sample_openface_csv()), *common, name="points")
    for name in ("control", "translator", "features", "points"):
        spawn.wait_for_line(name, f"waiting for the Zenoh router at {router}", timeout=30)
    time.sleep(3.0)  # still waiting, and said so only once
    for name in ("control", "translator", "features", "points"):
        assert spawn.log(name).count("waiting for the Zenoh router") == 1, spawn.log(name)
    spawn("router", "--listen", router, name="router")
    for name in ("control", "translator", "features", "points"):
        line = spawn.wait_for_line(name, "connected to the router after", timeout=30)
        assert float(line.rsplit("after ", 1)[1].split()[0]) >= 3.0
    sensor = run_facesynth(
        "sensor", "--ticks", "30", "--fast", "--wait-for", "points,features,translator,control",
        "--wait-timeout", "30", *common,
    )  # fmt: skip
    assert sensor.returncode == 0, sensor.stderr
    deadline = time.monotonic() + 30
    frames: list[int | None] = []
    while time.monotonic() < deadline and 29 not in frames:
        frames = [line.frame for line in read_record(out)]
        time.sleep(0.1)
    assert [f for f in frames if f is not None] == list(range(30)), spawn.log("control")


def test_with_a_router_timeout_a_service_gives_up_with_one_line(tmp_path: Path) -> None:
    router = f"tcp/127.0.0.1:{free_port()}"
    started = time.monotonic()
    result = run_facesynth("features", "--connect", router, "--router-timeout", "1.5")
    elapsed = time.monotonic() - started
    assert result.returncode == 2
    assert "facesynth features: error: cannot open a Zenoh client session" in result.stderr
    assert "Traceback" not in result.stderr
    assert 1.4 < elapsed < 20


def test_a_recorder_started_before_its_router_waits_then_records(
    spawn: Processes, tmp_path: Path
) -> None:
    """record is a long-running recorder: it waits for its router as the services do (issue
    29: it used to fail at once), and records what is published once the router is up."""
    import json
    import signal

    from facesynth.app.recording.reader import Recording

    router = f"tcp/127.0.0.1:{free_port()}"
    session = tmp_path / "s.mcap"
    common = ["--connect", router, "--rig", "records"]
    recorder = spawn("record", "--out", str(session), *common, name="record")
    spawn.wait_for_line("record", f"waiting for the Zenoh router at {router}", timeout=30)
    time.sleep(2.5)  # past a one-shot tool's wait: still waiting
    assert recorder.poll() is None, spawn.log("record")
    spawn("router", "--listen", router, name="router")
    spawn.wait_for_line("record", "connected to the router after", timeout=30)
    spawn.wait_for_line("record", "recording", timeout=30)
    sensor = run_facesynth("sensor", "--ticks", "5", "--fps", "30", *common)
    assert sensor.returncode == 0, sensor.stderr
    time.sleep(1.0)
    recorder.send_signal(signal.SIGINT)
    assert recorder.wait(timeout=30) == 0, spawn.log("record")
    summary = json.loads(spawn.log("record").strip().splitlines()[-1])
    assert summary["by_key"].get("facesynth/records/input") == 5, summary
    with Recording(session) as recording:
        assert "input" in recording.stages()
