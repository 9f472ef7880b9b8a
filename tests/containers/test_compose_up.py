"""``docker-compose up`` runs the chain in containers on Podman, plain and secured.

Builds the images through the compose file (from a base image made locally with debootstrap),
starts the router and the five services, and checks that servo commands for the sample video
come out in ./recordings; then ``down`` returns the face to neutral. Prints the build time and
the image sizes.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import zenoh
from container_engine import Engine, free_port, project_name, writable_by_services

from facesynth.runtime import codec, keys
from facesynth.runtime.profiles import load_profile
from schemas.messages import ServoCommands
from services.control.drivers.record import RecordLine, read_record

SERVOS = {spec.name: spec for spec in load_profile("paper16").servos}


def _compose(engine: Engine, project: Path, name: str, port: int, *files: str):  # type: ignore[no-untyped-def]
    args = ["docker-compose", "-p", name]
    for file in files:
        args += ["-f", file]
    engine.env["FACESYNTH_ROUTER_PORT"] = str(port)

    def run(
        *argv: str, timeout: float = 900, check: bool = True
    ) -> subprocess.CompletedProcess[str]:
        return engine.run(*args, *argv, cwd=project, timeout=timeout, check=check)

    return run


def _commands(path: Path, count: int, timeout: float, logs) -> list[RecordLine]:  # type: ignore[no-untyped-def]
    deadline = time.monotonic() + timeout
    moved: list[RecordLine] = []
    while time.monotonic() < deadline:
        if path.exists():
            moved = [line for line in read_record(path) if line.frame is not None]
            if len(moved) >= count:
                return moved
        time.sleep(1.0)
    raise AssertionError(f"{len(moved)} of {count} commands after {timeout} s:\n{logs()}")


def _check_commands(lines: list[RecordLine]) -> None:
    frames = [line.frame for line in lines]
    assert frames == sorted(frames), "commands arrive in frame order"
    for line in lines:
        assert line.servos.keys() == SERVOS.keys()
        for servo, value in line.servos.items():
            assert SERVOS[servo].min_us <= value <= SERVOS[servo].max_us
    assert any(v != SERVOS[s].neutral_us for line in lines for s, v in line.servos.items()), (
        "the performer's face must move some servo"
    )


def _image_size(engine: Engine, image: str) -> int:
    return int(engine.run("podman", "image", "inspect", "--format", "{{.Size}}", image).stdout)


def _healthy(engine: Engine, container: str, timeout: float = 60) -> None:
    deadline = time.monotonic() + timeout
    while True:
        result = engine.run("podman", "healthcheck", "run", container, check=False)
        if result.returncode == 0:
            return
        assert time.monotonic() < deadline, f"{container} unhealthy: {result.stdout}{result.stderr}"
        time.sleep(2)


def test_compose_up_runs_the_chain(engine: Engine, project: Path) -> None:
    name = project_name()
    compose = _compose(engine, project, name, free_port())
    recordings = writable_by_services(project / "recordings")
    started = time.monotonic()
    compose("build")
    built = time.monotonic() - started
    full = _image_size(engine, "facesynth:latest")
    board = _image_size(engine, "facesynth-board:latest")
    print(
        f"\ncompose build: {built:.1f} s; image sizes: facesynth {full / 1e6:.0f} MB, "
        f"facesynth-board {board / 1e6:.0f} MB"
    )
    assert board < full * 0.7, "the board image leaves OpenCV and the tracker out"
    logs = lambda: compose("logs", "--tail", "30", check=False).stdout  # noqa: E731
    try:
        started = time.monotonic()
        compose("up", "-d")
        lines = _commands(recordings / "commands.jsonl", 90, 300, logs)
        print(f"compose up: 90 commands {time.monotonic() - started:.1f} s after `up -d`")
        _check_commands(lines)
        _healthy(engine, f"{name}_control_1")
        _healthy(engine, f"{name}_router_1")
        # A container whose service is gone is unhealthy: the check is real.
        compose("stop", "translator")
        unhealthy = engine.run(
            "podman",
            "exec",
            f"{name}_control_1",
            "facesynth",
            "health",
            "--host",
            "nobody",
            check=False,
        )
        assert unhealthy.returncode == 1, unhealthy.stdout
    finally:
        compose("down", "--timeout", "20", check=False)
    ps = engine.run("podman", "ps", "-a", "--filter", f"name={name}_", "--format", "{{.Names}}")
    assert ps.stdout.strip() == "", "down removes every container"
    last = read_record(recordings / "commands.jsonl")[-1]
    assert last.frame is None and all(
        value == SERVOS[servo].neutral_us for servo, value in last.servos.items()
    ), "stopping the controller puts the face back to neutral"


def test_secured_compose_runs_the_chain_and_refuses_strangers(
    engine: Engine, project: Path
) -> None:
    certs = writable_by_services(project / "certs")
    subprocess.run(
        [sys.executable, "-m", "facesynth", "certs", "default", "--out", str(certs)],
        check=True,
        capture_output=True,
        timeout=60,
    )
    for path in certs.iterdir():
        os.chown(path, 10001, 10001)
    recordings = writable_by_services(project / "recordings")
    (recordings / "commands.jsonl").unlink(missing_ok=True)
    port = free_port()
    name = project_name()
    compose = _compose(
        engine, project, name, port, "docker-compose.yml", "docker-compose.secure.yml"
    )
    logs = lambda: compose("logs", "--tail", "30", check=False).stdout  # noqa: E731
    try:
        compose("up", "-d")
        _check_commands(_commands(recordings / "commands.jsonl", 60, 300, logs))
        _healthy(engine, f"{name}_router_1")
        # Someone on the network without the rig's certificate gets no session.
        stranger = zenoh.Config()
        stranger.insert_json5("mode", '"client"')
        stranger.insert_json5("connect/endpoints", f'["tcp/127.0.0.1:{port}"]')
        stranger.insert_json5("scouting/multicast/enabled", "false")
        try:
            zenoh.open(stranger).close()
        except zenoh.ZError:
            pass
        else:
            raise AssertionError("the secured router served a plain TCP session")
    finally:
        compose("down", "--timeout", "20", check=False)


def test_the_controller_swaps_to_the_virtual_face(engine: Engine, project: Path) -> None:
    page_port, router_port = free_port(), free_port()
    engine.env["FACESYNTH_PORT_8080"] = str(page_port)
    name = project_name()
    compose = _compose(
        engine, project, name, router_port, "docker-compose.yml", "docker-compose.virtual.yml"
    )
    logs = lambda: compose("logs", "--tail", "30", check=False).stdout  # noqa: E731
    applied: list[ServoCommands] = []
    try:
        compose("up", "-d")
        deadline = time.monotonic() + 300
        page = ""
        while time.monotonic() < deadline and "<html" not in page.lower():
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{page_port}/", timeout=5) as reply:
                    page = reply.read().decode(errors="replace")
            except OSError:
                time.sleep(2)
        assert "<html" in page.lower(), logs()
        # What the swapped controller applies, seen from the host through the router's port.
        config = zenoh.Config()
        config.insert_json5("mode", '"client"')
        config.insert_json5("connect/endpoints", f'["tcp/127.0.0.1:{router_port}"]')
        config.insert_json5("scouting/multicast/enabled", "false")
        session = zenoh.open(config)
        try:
            session.declare_subscriber(
                keys.stage_key("default", "servo_state"),
                lambda s: applied.append(codec.decode(s.payload.to_bytes(), ServoCommands)),
            )
            deadline = time.monotonic() + 120
            while time.monotonic() < deadline and len(applied) < 30:
                time.sleep(0.5)
        finally:
            session.close()
        assert len(applied) >= 30, logs()
        assert {message.profile for message in applied} == {"virtual"}
    finally:
        compose("down", "--timeout", "20", check=False)


def test_compose_files_validate_offline(engine: Engine, project: Path, tmp_path: Path) -> None:
    controllers = project / "deploy" / "controllers"
    controllers.mkdir(exist_ok=True)
    (controllers / "replay.toml").write_text(
        'rig = "default"\n[nodes.control]\nstage = "control"\nprofile = "paper16"\n'
        'driver = { driver = "record", out = "/recordings/other.jsonl" }\n'
    )
    subprocess.run(
        [
            sys.executable,
            "-m",
            "facesynth",
            "compose",
            "deploy/controllers/replay.toml",
            "--override",
            "--out",
            "docker-compose.replay.yml",
        ],
        cwd=project,
        check=True,
        capture_output=True,
        timeout=60,
    )
    for files in (
        ["docker-compose.yml"],
        ["docker-compose.yml", "docker-compose.secure.yml"],
        ["docker-compose.yml", "docker-compose.replay.yml"],
        ["docker-compose.yml", "deploy/zenohd/compose.yml"],
        ["docker-compose.yml", "docker-compose.virtual.yml"],
        ["docker-compose.yml", "docker-compose.arduino.yml"],
    ):
        args = [arg for file in files for arg in ("-f", file)]
        merged = engine.run("docker-compose", *args, "config", cwd=project).stdout
        assert "control" in merged
    merged = engine.run(
        "docker-compose",
        "-f",
        "docker-compose.yml",
        "-f",
        "docker-compose.replay.yml",
        "config",
        cwd=project,
    ).stdout
    assert "/etc/facesynth/controllers/replay.toml" in merged
