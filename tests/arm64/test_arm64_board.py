"""The board side on arm64 (a Raspberry Pi), under qemu-user emulation.

The arm64 board image, built from the same Dockerfile as the amd64 one, runs the board graph
(router, features, translator, control recording) in four containers; this machine's x86 Python
replays a recorded session into it over Zenoh, and the recorded servo commands must equal the
x86 run of the same replay. A plain ``pip install .`` in a fresh arm64 venv installs the board
side without OpenCV or an inference runtime; the tracker extra then installs on top (LiteRT's
aarch64 wheel and OpenCV's), and a few frames of the sample video are tracked with OpenCV DNN
(LiteRT's aarch64 build crashes or hangs under qemu-user here, so it is installed, not run).
Timing under emulation means nothing; function does. Prints the group's times.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import BOARD_IMAGE, PLATFORM, TRACKED_FRAMES, TRACKED_RUNTIMES, Arm64

from facesynth.runtime.profiles import load_profile
from facesynth.services.control.drivers.record import RecordLine, read_record

ROOT = Path(__file__).resolve().parents[2]
SAMPLE_CSV = ROOT / "facesynth" / "app" / "data" / "OpenFace_Test.csv"
SERVOS = {spec.name: spec for spec in load_profile("paper16").servos}
BOARD_NODES = ("features", "translator", "control")


def _facesynth(*argv: str, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    result = subprocess.run(
        [sys.executable, "-m", "facesynth", *argv],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    assert result.returncode == 0, f"facesynth {argv[0]}: {result.stderr[-3000:]}"
    return result


def _moves(path: Path) -> list[tuple[int, dict[str, float]]]:
    return [(line.frame, line.servos) for line in read_record(path) if line.frame is not None]


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A recorded session: the OpenFace sample through the x86 chain, every key recorded."""
    folder = tmp_path_factory.mktemp("session")
    recording = folder / "session.mcap"
    _facesynth(
        "run",
        "--openface-csv",
        str(SAMPLE_CSV),
        "--fast",
        "--listen",
        "tcp/127.0.0.1:0",
        "--out",
        str(folder / "live.jsonl"),
        "--record",
        str(recording),
    )
    return recording


def _free_port() -> int:
    import socket

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _wait_for_log(arm64: Arm64, container: str, pattern: str, timeout: float = 300) -> None:
    deadline = time.monotonic() + timeout
    while True:
        logs = arm64.podman.run("podman", "logs", container, check=False)
        if re.search(pattern, logs.stdout + logs.stderr):
            return
        running = arm64.podman.run(
            "podman", "inspect", "--format", "{{.State.Running}}", container, check=False
        )
        assert running.stdout.strip() == "true", f"{container} stopped:\n{logs.stderr[-3000:]}"
        assert time.monotonic() < deadline, f"{container}: no {pattern!r}:\n{logs.stderr[-3000:]}"
        time.sleep(1.0)


def test_the_arm64_board_image_runs_the_board_graph_like_x86(
    arm64: Arm64, session: Path, tmp_path: Path
) -> None:
    arch = arm64.podman.run(
        "podman", "image", "inspect", "--format", "{{.Architecture}}", BOARD_IMAGE
    )
    assert arch.stdout.strip() == "arm64"
    machine = arm64.podman.run(
        "podman", "run", "--rm", "--platform", PLATFORM, "--entrypoint", "uname", BOARD_IMAGE, "-m"
    )
    assert machine.stdout.strip() == "aarch64", "the board image's programs are arm64 programs"
    # The x86 run of the replay: F, T, C of the same graph in one process on this machine.
    graph = str(ROOT / "deploy" / "graph.toml")
    x86 = tmp_path / "x86.jsonl"
    replay = ["replay", str(session), "--from", "points", "--fast"]
    # --motion-time media: speed limits on the commands' media time, so both runs are
    # deterministic (a --fast replay to a recording driver).
    _facesynth(
        *replay,
        "--graph",
        graph,
        "--motion-time",
        "media",
        "--out",
        str(x86),
        "--listen",
        "tcp/127.0.0.1:0",
    )
    # The same graph's board nodes, each in its own arm64 container, around an arm64 router.
    recordings = tmp_path / "recordings"
    recordings.mkdir()
    import os

    os.chown(recordings, 10001, 10001)
    port = _free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    name = f"fsarm{port}"
    common = ["podman", "run", "-d", "--platform", PLATFORM, "--network", "host"]
    common += ["-v", f"{arm64.project / 'deploy'}:/etc/facesynth:ro"]
    containers = [f"{name}-router", *(f"{name}-{node}" for node in BOARD_NODES)]
    started = time.monotonic()
    try:
        arm64.podman.run(
            *common, "--name", containers[0], BOARD_IMAGE, "router", "--listen", endpoint
        )
        for node, container in zip(BOARD_NODES, containers[1:], strict=True):
            extra = ["-v", f"{recordings}:/recordings"] if node == "control" else []
            flags = ["--motion-time", "media"] if node == "control" else []
            arm64.podman.run(
                *common,
                *extra,
                "--name",
                container,
                BOARD_IMAGE,
                node,
                "--graph",
                "/etc/facesynth/graph.toml",
                "--node",
                node,
                "--connect",
                endpoint,
                *flags,
            )
        _wait_for_log(arm64, containers[0], "listening on")
        fed = _facesynth(
            *replay,
            "--mode",
            "client",
            "--connect",
            endpoint,
            "--wait-for",
            ",".join(BOARD_NODES),
            "--wait-timeout",
            "600",
            # The emulated router answers a session's handshake slowly while the install job
            # and the other CI lane load both cores (2 s, the default, ran out on CI once).
            "--router-timeout",
            "300",
            timeout=900,
        )
        assert json.loads(fed.stdout.strip().splitlines()[-1])["published"] == 100
        record = recordings / "commands.jsonl"
        deadline = time.monotonic() + 120
        while len(_moves(record) if record.exists() else []) < 100:
            assert time.monotonic() < deadline, "the arm64 controller recorded too few commands"
            time.sleep(0.5)
        arm64.podman.run("podman", "stop", "-t", "30", containers[-1])
        arm64.timings["board graph"] = time.monotonic() - started
        code = arm64.podman.run(
            "podman", "inspect", "--format", "{{.State.ExitCode}}", containers[-1]
        )
        assert code.stdout.strip() == "0", "the arm64 controller stops cleanly"
    finally:
        for container in containers:
            arm64.podman.run("podman", "rm", "-f", "-t", "5", container, check=False)
    on_arm64, on_x86 = _moves(record), _moves(x86)
    assert len(on_x86) == 100
    # Same commands: the board side computes in float64 the same way on both architectures.
    assert on_arm64 == on_x86
    assert any(v != SERVOS[s].neutral_us for _, servos in on_arm64 for s, v in servos.items())
    last: RecordLine = read_record(record)[-1]
    assert last.frame is None and all(
        value == SERVOS[servo].neutral_us for servo, value in last.servos.items()
    ), "stopping the arm64 controller puts the face back to neutral"


def test_a_plain_pip_install_on_arm64_is_the_board_side(arm64: Arm64) -> None:
    plain = json.loads(arm64.install.wait_for("plain.json").read_text())
    assert plain["machine"] == "aarch64"
    assert set(plain["missing"]) == {"cv2", "ai_edge_litert", "sklearn"}, (
        "pip install . brings no OpenCV, inference runtime or scikit-learn"
    )
    arm64.install.wait_for("plain.ok")  # control, translator, features and router --help ran


def test_the_tracker_extra_installs_on_arm64_and_tracks_the_sample(arm64: Arm64) -> None:
    arm64.install.wait_for("done.ok")
    times = (arm64.install.out / "times.txt").read_text()
    arm64.timings["install job"] = time.monotonic() - arm64.install.started
    print("\narm64 install job (emulated):\n" + times)
    installed = {
        p["name"].lower(): p["version"]
        for p in json.loads((arm64.install.out / "tracker-packages.json").read_text())
    }
    # ai-edge-litert publishes manylinux_2_27_aarch64 wheels (Debian bookworm's glibc is 2.36).
    assert "ai-edge-litert" in installed and "opencv-python-headless" in installed, installed
    for runtime in TRACKED_RUNTIMES:
        log = (arm64.install.out / f"track-{runtime}.log").read_text()
        stdout = (arm64.install.out / f"track-{runtime}.json").read_text()
        summary = json.loads(stdout.strip().splitlines()[-1])
        assert summary["frames"] == TRACKED_FRAMES, log
        lines = [
            line
            for line in read_record(arm64.install.out / f"track-{runtime}.jsonl")
            if line.frame is not None
        ]
        assert len(lines) == TRACKED_FRAMES, log
        assert all(line.face for line in lines), f"{runtime}: the performer's face is found"
