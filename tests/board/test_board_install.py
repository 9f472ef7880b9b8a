"""C alone on a small board: ``pip install .`` without extras, the systemd unit, a secured link.

A fresh venv gets facesynth with only its base dependencies (no OpenCV, no inference runtime);
the unit's own ExecStart, with its paths moved into a temporary folder, runs the control
interface against a secured router, and only the translator's certificate moves a servo.
Prints the board-side install size.
"""

from __future__ import annotations

import json
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
import zenoh
from host_requirements import require_packages

from facesynth.app.certs import CertRequest, make_certs
from facesynth.runtime import codec, keys
from facesynth.schemas.messages import ServoCommands
from facesynth.services.control.drivers.record import read_record

ROOT = Path(__file__).resolve().parents[2]
UNIT = ROOT / "deploy" / "board" / "facesynth-control.service"


def _size_mb(folder: Path) -> float:
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file()) / 1e6


@pytest.fixture(scope="module")
def board_venv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A venv with ``pip install .`` and nothing else (as on a Raspberry Pi-class board)."""
    venv = tmp_path_factory.mktemp("board") / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, timeout=120)
    started = time.monotonic()
    install = subprocess.run(
        [str(venv / "bin" / "pip"), "install", "-q", str(ROOT)],
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert install.returncode == 0, install.stdout + install.stderr
    site = next((venv / "lib").glob("python3*/site-packages"))
    tooling = ("pip", "setuptools", "_distutils_hack", "pkg_resources")
    own = [p for p in site.iterdir() if p.name.split("-")[0] not in tooling]
    size = sum(_size_mb(p) if p.is_dir() else p.stat().st_size / 1e6 for p in own)
    packages = sorted(p.name.split("-")[0] for p in site.glob("*.dist-info"))
    print(
        f"\nboard install (pip install ., no extras): {size:.0f} MB for facesynth and its "
        f"dependencies (site-packages {_size_mb(site):.0f} MB with the venv's pip and "
        f"setuptools), installed in {time.monotonic() - started:.0f} s: {', '.join(packages)}"
    )
    return venv


def test_the_board_install_has_no_opencv_or_inference_runtime(board_venv: Path) -> None:
    python = str(board_venv / "bin" / "python")
    for module in ("cv2", "ai_edge_litert"):
        probe = subprocess.run([python, "-c", f"import {module}"], capture_output=True, timeout=60)
        assert probe.returncode != 0, f"{module} is installed on the board side"
    for stage in ("control", "translator", "features", "router", "status", "health"):
        help_run = subprocess.run(
            [str(board_venv / "bin" / "facesynth"), stage, "--help"],
            capture_output=True,
            text=True,
            timeout=60,
        )
        assert help_run.returncode == 0, help_run.stderr


def test_the_board_install_puts_only_facesynth_at_the_top(board_venv: Path) -> None:
    site = next((board_venv / "lib").glob("python3*/site-packages"))
    (record,) = site.glob("facesynth-*.dist-info/RECORD")
    tops = {line.split(",")[0].split("/")[0] for line in record.read_text().splitlines()}
    tops = {top for top in tops if not top.endswith(".dist-info") and top != ".."}
    assert tops == {"facesynth"}, sorted(tops)
    assert not (site / "services").exists() and not (site / "schemas").exists()


def test_systemd_accepts_the_unit(board_venv: Path, tmp_path: Path) -> None:
    require_packages("the board's unit test", "board")
    unit = tmp_path / "facesynth-control.service"
    unit.write_text(UNIT.read_text().replace("/opt/facesynth", str(board_venv)))
    result = subprocess.run(
        ["systemd-analyze", "verify", str(unit)], capture_output=True, text=True, timeout=120
    )
    problems = [line for line in result.stderr.splitlines() if unit.name in line]
    assert result.returncode == 0 and not problems, result.stderr


@pytest.fixture
def secured_router(tmp_path: Path) -> Iterator[tuple[Path, str]]:
    """The rig's certificates (made where ``cryptography`` is) and a secured router."""
    certs = tmp_path / "certs"
    make_certs(CertRequest(rig="default", out=certs))
    log = tmp_path / "router.log"
    with open(log, "wb") as out:
        router = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "facesynth",
                "router",
                "--zenoh-config",
                str(certs / "router.json5"),
                "--listen",
                "tls/127.0.0.1:0",
            ],
            stdout=out,
            stderr=subprocess.STDOUT,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )
    try:
        deadline = time.monotonic() + 20
        while not (match := re.search(r"tls/127\.0\.0\.1:(\d+)", log.read_text())):
            assert time.monotonic() < deadline, log.read_text()
            time.sleep(0.05)
        yield certs, f"tls/localhost:{match.group(1)}"
    finally:
        router.send_signal(signal.SIGTERM)
        router.wait(timeout=15)


def test_the_units_command_runs_the_board_side(
    board_venv: Path, secured_router: tuple[Path, str], tmp_path: Path
) -> None:
    certs, endpoint = secured_router
    etc = tmp_path / "etc"
    state = tmp_path / "state"
    state.mkdir()
    etc.mkdir()
    graph = (ROOT / "deploy" / "board" / "control.toml").read_text()
    (etc / "control.toml").write_text(graph.replace("/var/lib/facesynth", str(state)))
    shutil.copytree(certs, etc / "certs")
    config = json.loads(
        "\n".join(
            line
            for line in (certs / "control.json5").read_text().splitlines()
            if not line.startswith("//")
        )
    )
    config["connect"]["endpoints"] = [endpoint]
    (etc / "certs" / "control.json5").write_text(json.dumps(config))
    exec_start = next(
        line.split("=", 1)[1]
        for line in UNIT.read_text().splitlines()
        if line.startswith("ExecStart=")
    )
    argv = [
        part.replace("/opt/facesynth", str(board_venv)).replace("/etc/facesynth", str(etc))
        for part in shlex.split(exec_start)
    ]
    log = tmp_path / "control.log"
    with open(log, "wb") as out:
        control = subprocess.Popen(argv, stdout=out, stderr=subprocess.STDOUT)
    record = state / "commands.jsonl"
    try:
        deadline = time.monotonic() + 30
        while "control interface on" not in log.read_text():
            assert control.poll() is None and time.monotonic() < deadline, log.read_text()
            time.sleep(0.1)
        key = keys.stage_key("default", "servo_commands")
        for identity, jaw in (("features", 1100.0), ("translator", 1900.0)):
            client = zenoh.Config.from_file(str(certs / f"{identity}.json5"))
            client.insert_json5("connect/endpoints", json.dumps([endpoint]))
            session = zenoh.open(client)
            try:
                time.sleep(0.3)
                for seq in range(3):
                    session.put(
                        key,
                        codec.encode(
                            ServoCommands(
                                seq=seq,
                                t_capture_ns=1,
                                t_media_ns=1,
                                face=True,
                                profile="paper16",
                                positions={"jaw": jaw},
                            )
                        ),
                    )
                    time.sleep(0.05)
                time.sleep(0.5)
            finally:
                session.close()
        moved = [line for line in read_record(record) if line.frame is not None]
        # Only the translator's three commands move the jaw, toward its 1900 within paper16's
        # speed limits (the control interface ramps); the features identity's 1100 never.
        jaws = [line.servos["jaw"] for line in moved]
        assert len(jaws) == 3 and all(1500.0 < jaw <= 1900.0 for jaw in jaws), log.read_text()
        assert jaws == sorted(jaws), jaws
        mapped = Path(f"/proc/{control.pid}/maps").read_text()
        assert "cv2" not in mapped and "opencv" not in mapped
    finally:
        control.send_signal(signal.SIGTERM)
        assert control.wait(timeout=15) == 0, log.read_text()
    assert read_record(record)[-1].frame is None, "stopping puts the face back to neutral"


def test_the_pca9685_extra_adds_smbus2_and_no_opencv(board_venv: Path) -> None:
    """A Pi driving a PCA9685 on its own I2C pins: ``pip install '.[pca9685]'`` on the board
    install adds smbus2 only, and the driver's missing bus is one line, from the real smbus2.
    (Runs last in this module: the venv gains smbus2, which the tests above never look for.)"""
    install = subprocess.run(
        [str(board_venv / "bin" / "pip"), "install", "-q", f"{ROOT}[pca9685]"],
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert install.returncode == 0, install.stdout + install.stderr
    python = str(board_venv / "bin" / "python")
    for module, present in (("smbus2", True), ("cv2", False), ("ai_edge_litert", False)):
        probe = subprocess.run([python, "-c", f"import {module}"], capture_output=True, timeout=60)
        assert (probe.returncode == 0) == present, module
    status = subprocess.run(
        [str(board_venv / "bin" / "facesynth"), "control", "status", "--driver", "pca9685",
         "--i2c-bus", "/dev/i2c-99"],
        capture_output=True,
        text=True,
        timeout=60,
    )  # fmt: skip
    assert status.returncode == 2
    assert status.stderr.strip() == (
        "facesynth control: error: /dev/i2c-99: cannot open it: No such file or directory"
    )
