"""arm64 (a Raspberry Pi's architecture) under qemu-user emulation: marked ``arm64``, left out of
``make test``; ``make test-arm64`` (and ``.ci/run``) runs them.

They need root, podman, runc, debootstrap and qemu-user-static with binfmt_misc (``.ci/run``
installs and mounts them); without them they fail and say what is missing. One session makes
the arm64 base image (``deploy/base-image.sh --arch arm64``), starts the plain ``pip install .``
in a container of it (``install_on_arm64.sh``) and, meanwhile, builds the arm64 board image
from the Dockerfile: the two emulated jobs use the machine's two cores at once.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest
from host_requirements import require_root_and_tools

ROOT = Path(__file__).resolve().parents[2]
BASE_IMAGE = os.environ.get("FACESYNTH_TEST_ARM64_BASE", "localhost/facesynth-base:bookworm-arm64")
BOARD_IMAGE = "localhost/facesynth-board:arm64"
#: The board image's extras, as docker-compose.yml builds facesynth-board.
BOARD_EXTRAS = "fast,face"
#: Frames of the sample video tracked under emulation.
TRACKED_FRAMES = 6
#: The tracker runtimes run under emulation: OpenCV DNN. ai-edge-litert installs on aarch64
#: (manylinux_2_27_aarch64 wheels) but crashes or hangs under qemu-user on this machine kind.
TRACKED_RUNTIMES = ("opencv",)
#: What the build context and the install need (tests and caches stay out).
PROJECT_FILES = [
    "Dockerfile",
    ".dockerignore",
    "pyproject.toml",
    "README.md",
    "LICENSE",
    "deploy",
    "facesynth",
    "schemas",
    "services",
]
#: The CA of a TLS-intercepting proxy, handed to pip when present (as tests/containers does).
HOST_CA = Path("/etc/ssl/certs/ca-certificates.crt")
PLATFORM = "linux/arm64"


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        if Path(str(item.fspath)).is_relative_to(Path(__file__).parent):
            item.add_marker(pytest.mark.arm64)
            item.add_marker(pytest.mark.timeout(1800))


def _require() -> None:
    """Fail (never skip) with what is missing."""
    require_root_and_tools("the arm64 tests", "arm64", "run a rootful Podman")
    probe = subprocess.run(["arch-test", "arm64"], capture_output=True, text=True, timeout=60)
    if probe.returncode != 0:
        pytest.fail(
            "this machine cannot run arm64 programs: make test-arm64 registers qemu-aarch64 "
            "in binfmt_misc (tools/system-packages.sh arm64), as root: "
            f"{probe.stdout}{probe.stderr}"
        )


@dataclass
class Podman:
    """Rootful Podman with the project's settings (deploy/podman-containers.conf)."""

    env: dict[str, str]

    def run(
        self, *argv: str, cwd: Path | None = None, timeout: float = 900, check: bool = True
    ) -> subprocess.CompletedProcess[str]:
        result = subprocess.run(
            list(argv), cwd=cwd, env=self.env, capture_output=True, text=True, timeout=timeout
        )
        if check and result.returncode != 0:
            raise AssertionError(
                f"{' '.join(argv)} failed ({result.returncode}):\n"
                f"{result.stdout[-3000:]}\n{result.stderr[-3000:]}"
            )
        return result


@dataclass
class InstallJob:
    """The emulated ``pip install .`` (then the tracker extra and a few tracked frames)."""

    process: subprocess.Popen[bytes]
    out: Path
    log: Path
    started: float

    def wait_for(self, name: str, timeout: float = 1500) -> Path:
        """The result file ``name`` once the job wrote it (fails with the job's log if it ended
        without it)."""
        path = self.out / name
        deadline = time.monotonic() + timeout
        while not path.exists():
            assert self.process.poll() is None or path.exists(), (
                f"the arm64 install job ended ({self.process.returncode}) without {name}:\n"
                + self.log.read_text()[-4000:]
            )
            assert time.monotonic() < deadline, f"no {name} after {timeout} s"
            time.sleep(1.0)
        return path


@dataclass
class Arm64:
    """What the arm64 tests share: the engine, the project copy, the images and the job."""

    podman: Podman
    project: Path
    install: InstallJob
    timings: dict[str, float]


@pytest.fixture(scope="session")
def arm64(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Arm64]:
    _require()
    session_started = time.monotonic()
    podman = Podman(
        {**os.environ, "CONTAINERS_CONF": str(ROOT / "deploy" / "podman-containers.conf")}
    )
    project = tmp_path_factory.mktemp("project")
    for name in PROJECT_FILES:
        source = ROOT / name
        if source.is_dir():
            shutil.copytree(
                source, project / name, ignore=shutil.ignore_patterns("__pycache__", "*.crt")
            )
        else:
            shutil.copy2(source, project / name)
    timings: dict[str, float] = {}
    started = time.monotonic()
    podman.run(str(ROOT / "deploy" / "base-image.sh"), "--arch", "arm64", BASE_IMAGE, timeout=1500)
    timings["base image"] = time.monotonic() - started
    install = _start_install(podman, project, tmp_path_factory.mktemp("arm64-install"))
    try:
        started = time.monotonic()
        build = ["podman", "build", "--platform", PLATFORM, "--build-arg"]
        build += [f"BASE_IMAGE={BASE_IMAGE}", "--build-arg", f"EXTRAS={BOARD_EXTRAS}"]
        if HOST_CA.is_file():
            build += ["--secret", f"id=pip_ca,src={HOST_CA}"]
        podman.run(*build, "-t", BOARD_IMAGE, ".", cwd=project, timeout=1500)
        timings["board image"] = time.monotonic() - started
        yield Arm64(podman, project, install, timings)
    finally:
        if install.process.poll() is None:
            install.process.terminate()
            try:
                install.process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                install.process.kill()
                install.process.wait()
        timings["session"] = time.monotonic() - session_started
        print("\narm64 group: " + ", ".join(f"{k} {v:.0f} s" for k, v in timings.items()))


def _start_install(podman: Podman, project: Path, out: Path) -> InstallJob:
    os.chmod(out, 0o777)
    log = out.parent / "install.log"
    argv = ["podman", "run", "--rm", "--platform", PLATFORM, "--network", "host"]
    argv += ["-e", f"FRAMES={TRACKED_FRAMES}", "-e", f"RUNTIMES={' '.join(TRACKED_RUNTIMES)}"]
    argv += ["-v", f"{project}:/src:ro", "-v", f"{out}:/out"]
    argv += ["-v", f"{Path(__file__).parent / 'install_on_arm64.sh'}:/install.sh:ro"]
    if HOST_CA.is_file():
        argv += ["-e", "PIP_CERT=/run/host-ca.crt", "-v", f"{HOST_CA}:/run/host-ca.crt:ro"]
    with open(log, "wb") as sink:
        process = subprocess.Popen(
            [*argv, BASE_IMAGE, "sh", "/install.sh"],
            env=podman.env,
            stdout=sink,
            stderr=subprocess.STDOUT,
        )
    return InstallJob(process, out, log, time.monotonic())
