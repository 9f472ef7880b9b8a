"""A real container engine for the compose tests: Podman behind its Docker API, docker-compose v1.

Compose runs in a copy of the project made by an ordinary user (uid 1000), as their ``git clone``
would be, with no variable set and nothing chowned: as a new user runs it. The one thing this
machine lacks is a registry to pull the Dockerfile's default base image ``python:3.11-slim``
from, so the engine gets it beforehand under that name (``docker.io/library/python:3.11-slim``,
what a user's engine would have pulled): a Debian bookworm with python3 made by
``deploy/base-image.sh`` with debootstrap. An image of that name already in the engine is kept.

These tests need root, podman, runc, docker-compose and debootstrap (``.ci/run`` installs them);
without them they fail and say what is missing. They are marked ``containers`` and left out of
``make test``; ``make test-containers`` (and ``.ci/run``) runs them.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from container_engine import CLONE_USER, ROOT, Engine, project_name, require

#: The image deploy/base-image.sh makes, and the name the Dockerfile's default base resolves to.
LOCAL_BASE = "localhost/facesynth-base:bookworm"
DEFAULT_BASE = "docker.io/library/python:3.11-slim"
#: What the build context needs (the rest of the repository stays out of the copy).
PROJECT_FILES = [
    "Dockerfile",
    ".dockerignore",
    "docker-compose.yml",
    "docker-compose.secure.yml",
    "docker-compose.virtual.yml",
    "docker-compose.arduino.yml",
    "pyproject.toml",
    "README.md",
    "LICENSE",
    "recordings",
    "deploy",
    "facesynth",
    "schemas",
    "services",
]
#: The CA of a TLS-intercepting proxy, handed to pip in the image build when present.
HOST_CA = Path("/etc/ssl/certs/ca-certificates.crt")


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        if Path(str(item.fspath)).is_relative_to(Path(__file__).parent):
            item.add_marker(pytest.mark.containers)
            item.add_marker(pytest.mark.timeout(1500))


@pytest.fixture(scope="session")
def engine(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Engine]:
    require()
    folder = tmp_path_factory.mktemp("podman")
    socket_path = folder / "podman.sock"
    env = {
        **os.environ,
        "CONTAINERS_CONF": str(ROOT / "deploy" / "podman-containers.conf"),
        "DOCKER_HOST": f"unix://{socket_path}",
    }
    for name in [name for name in env if name.startswith("FACESYNTH_")]:
        del env[name]  # as a new user's shell: no variable set
    with open(folder / "service.log", "wb") as log:
        service = subprocess.Popen(
            ["podman", "system", "service", "--time=0", f"unix://{socket_path}"],
            env=env,
            stdout=log,
            stderr=subprocess.STDOUT,
        )
    try:
        deadline = time.monotonic() + 30
        while not socket_path.exists():
            assert service.poll() is None, (folder / "service.log").read_text()
            assert time.monotonic() < deadline, "podman system service did not start"
            time.sleep(0.1)
        engine = Engine(env)
        started = time.monotonic()
        if engine.run("podman", "image", "exists", DEFAULT_BASE, check=False).returncode != 0:
            engine.run(str(ROOT / "deploy" / "base-image.sh"), LOCAL_BASE, timeout=900)
            engine.run("podman", "tag", LOCAL_BASE, DEFAULT_BASE)
        print(f"\nbase image {DEFAULT_BASE}: ready in {time.monotonic() - started:.1f} s")
        yield engine
    finally:
        service.send_signal(signal.SIGTERM)
        try:
            service.wait(timeout=15)
        except subprocess.TimeoutExpired:
            service.kill()
            service.wait()


def as_clone_user(*argv: str, cwd: Path | None = None) -> None:
    """Run ``argv`` as CLONE_USER (as they would in their own shell)."""
    uid, gid = CLONE_USER
    subprocess.run(list(argv), cwd=cwd, user=uid, group=gid, check=True, timeout=120)


def _clone(home: Path, *, recordings: bool = True) -> Path:
    """A copy of the files the images and compose need, made by CLONE_USER in ``home``, in a
    folder whose name is a fresh compose project name; without ``recordings``, as a clone from
    before the folder was part of the project (the engine makes it at ``up``)."""
    folder = home / project_name()
    as_clone_user("mkdir", str(folder))
    names = [name for name in PROJECT_FILES if name != "recordings"]
    as_clone_user("cp", "-R", *(str(ROOT / name) for name in names), str(folder))
    if recordings:  # the folder as git has it: its .gitignore, none of this tree's recordings
        as_clone_user("mkdir", str(folder / "recordings"))
        as_clone_user("cp", str(ROOT / "recordings" / ".gitignore"), str(folder / "recordings"))
    for pattern in ("__pycache__", "*.crt"):
        for path in sorted(folder.rglob(pattern), reverse=True):
            shutil.rmtree(path) if path.is_dir() else path.unlink()
    if HOST_CA.is_file():
        shutil.copy2(HOST_CA, folder / "deploy" / "build-ca" / "ca.crt")
    return folder


@pytest.fixture(scope="session")
def home() -> Iterator[Path]:
    """CLONE_USER's home: a folder only they can write, outside root's private temp folder."""
    folder = Path(tempfile.mkdtemp(prefix="facesynth-home-"))
    os.chown(folder, *CLONE_USER)  # as useradd makes a home; nothing inside is chowned
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture(scope="session")
def project(home: Path) -> Path:
    """The user's clone: the project's files, its ``recordings`` folder with them."""
    return _clone(home)


@pytest.fixture
def clone_without_recordings(home: Path) -> Path:
    """A clone without the ``recordings`` folder: the engine makes it, owned by root."""
    return _clone(home, recordings=False)
