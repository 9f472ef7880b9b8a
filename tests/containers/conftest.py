"""A real container engine for the compose tests: Podman behind its Docker API, docker-compose v1.

These tests need root, podman, runc, docker-compose and debootstrap (``.ci/run`` installs them);
without them they fail and say what is missing. They are marked ``containers`` and left out of
``make test``; ``make test-containers`` (and ``.ci/run``) runs them.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from container_engine import ROOT, Engine, require

BASE_IMAGE = os.environ.get("FACESYNTH_TEST_BASE_IMAGE", "localhost/facesynth-base:bookworm")
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
    require("podman", "runc", "docker-compose", "debootstrap")
    folder = tmp_path_factory.mktemp("podman")
    socket_path = folder / "podman.sock"
    env = {
        **os.environ,
        "CONTAINERS_CONF": str(ROOT / "deploy" / "podman-containers.conf"),
        "DOCKER_HOST": f"unix://{socket_path}",
        "FACESYNTH_BASE_IMAGE": BASE_IMAGE,
    }
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
        engine.run(str(ROOT / "deploy" / "base-image.sh"), BASE_IMAGE, timeout=900)
        print(f"\nbase image {BASE_IMAGE}: ready in {time.monotonic() - started:.1f} s")
        yield engine
    finally:
        service.send_signal(signal.SIGTERM)
        try:
            service.wait(timeout=15)
        except subprocess.TimeoutExpired:
            service.kill()
            service.wait()


@pytest.fixture(scope="session")
def project(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A copy of the files the images and compose need (recordings and certs stay in it)."""
    folder = tmp_path_factory.mktemp("project")
    for name in PROJECT_FILES:
        source = ROOT / name
        if source.is_dir():
            shutil.copytree(
                source, folder / name, ignore=shutil.ignore_patterns("__pycache__", "*.crt")
            )
        else:
            shutil.copy2(source, folder / name)
    if HOST_CA.is_file():
        shutil.copy2(HOST_CA, folder / "deploy" / "build-ca" / "ca.crt")
    return folder
