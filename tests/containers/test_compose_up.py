"""``docker-compose up`` runs the chain in containers on Podman, plain and secured.

In a user's fresh clone (conftest: uid 1000, no variable, nothing chowned), builds the images
through the compose file, starts the router and the five services, and checks that servo
commands for the sample video come out in ./recordings, owned by that user; then ``down``
returns the face to neutral. Prints the build time and the image sizes. A recorder that cannot
write says so and exits non-zero, restarted by the engine, never recording nothing quietly.
"""

from __future__ import annotations

import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import zenoh
from conftest import as_clone_user
from container_engine import CLONE_USER, Engine, free_port, project_name

from facesynth.runtime import codec, keys
from facesynth.runtime.profiles import load_profile
from facesynth.schemas.messages import ServoCommands
from facesynth.services.control.drivers.record import RecordLine, read_record

SERVOS = {spec.name: spec for spec in load_profile("paper16").servos}


def _compose(  # type: ignore[no-untyped-def]
    engine: Engine,
    project: Path,
    *files: str,
    name: str | None = None,
    variables: dict[str, str] | None = None,
):
    """``docker-compose [-p NAME] [-f FILE]... ARGS`` in ``project``; without a name and
    variables, as a user types it in their clone (the project is named after its folder)."""
    args = ["docker-compose", *(["-p", name] if name else [])]
    for file in files:
        args += ["-f", file]

    def run(
        *argv: str, timeout: float = 900, check: bool = True
    ) -> subprocess.CompletedProcess[str]:
        return engine.run(
            *args, *argv, cwd=project, timeout=timeout, check=check, variables=variables
        )

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


def _default_router_port_is_free() -> None:
    with socket.socket() as probe:
        try:
            probe.bind(("0.0.0.0", 7447))
        except OSError:
            raise AssertionError(
                "a user's first `docker-compose up` publishes the router on port 7447, which "
                "something on this host holds: stop it and run again"
            ) from None


def test_compose_up_on_a_fresh_clone_records_the_chain(engine: Engine, project: Path) -> None:
    name = project.name  # what compose names the project after: the clone's folder
    compose = _compose(engine, project)
    recordings = project / "recordings"
    started = time.monotonic()
    compose("build")  # what the first `up` does; here also when older images are in the engine
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
        _default_router_port_is_free()
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
    owner = (recordings / "commands.jsonl").stat()
    assert (owner.st_uid, owner.st_gid) == CLONE_USER, "the recording is the clone owner's"
    last = read_record(recordings / "commands.jsonl")[-1]
    assert last.frame is None and all(
        value == SERVOS[servo].neutral_us for servo, value in last.servos.items()
    ), "stopping the controller puts the face back to neutral"


def test_secured_compose_runs_the_chain_and_refuses_strangers(
    engine: Engine, project: Path
) -> None:
    # The user makes the rig's certificates in their clone, keys readable by them only, and
    # nothing is chowned. (With the image's facesynth: this host's test interpreter lives in
    # root's home, out of the user's reach.)
    certs = project / "certs"
    as_clone_user("mkdir", str(certs))
    _compose(engine, project, name=project_name())(
        "run", "--rm", "--no-deps", "-v", f"{certs}:/certs", "sensor",
        "certs", "default", "--out", "/certs",
    )  # fmt: skip
    key = (certs / "control.key").stat()
    assert (key.st_uid, key.st_mode & 0o777) == (CLONE_USER[0], 0o600)
    recordings = project / "recordings"
    (recordings / "commands.jsonl").unlink(missing_ok=True)
    port, name = free_port(), project_name()
    compose = _compose(
        engine,
        project,
        "docker-compose.yml",
        "docker-compose.secure.yml",
        name=name,
        variables={"FACESYNTH_ROUTER_PORT": str(port)},
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
    compose = _compose(
        engine,
        project,
        "docker-compose.yml",
        "docker-compose.virtual.yml",
        name=project_name(),
        variables={
            "FACESYNTH_ROUTER_PORT": str(router_port),
            "FACESYNTH_PORT_8080": str(page_port),
        },
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


def test_a_recorder_that_cannot_write_fails_loudly(
    engine: Engine, clone_without_recordings: Path
) -> None:
    """A clone without ./recordings (from before the folder was in the project): the engine
    makes it at ``up``, owned by root, where the control service (the clone's owner) cannot
    write. It says so in one line, exits 2 and is restarted (``restart: on-failure``), each time
    with the line in its logs: never a chain that runs and records nothing."""
    project = clone_without_recordings
    name = project_name()
    compose = _compose(engine, project, name=name)
    container = f"{name}_control_1"
    error = (
        "facesynth control: error: cannot write record file /recordings/commands.jsonl: "
        "/recordings is not writable (Permission denied)"
    )
    try:
        compose("up", "-d", "--no-deps", "control")  # fails before it looks for its router
        deadline = time.monotonic() + 120
        while True:
            state = engine.run(
                "podman", "inspect", "--format", "{{.RestartCount}} {{.State.ExitCode}}", container
            ).stdout.split()
            logs = engine.run("podman", "logs", container, check=False)
            if int(state[0]) >= 1 and (logs.stdout + logs.stderr).count(error) >= 2:
                break
            assert time.monotonic() < deadline, f"{state}\n{logs.stdout}{logs.stderr}"
            time.sleep(1)
        assert int(state[1]) in (0, 2), state  # 0 while a restart runs, else the refusal's 2
    finally:
        compose("down", "--timeout", "20", check=False)
    made = (project / "recordings").stat()
    assert made.st_uid == 0 and not any((project / "recordings").iterdir())
