"""facesynth.app.doctor.serial_ports: who answers on each port, asked of real parts: our
firmware on the emulated Uno, the simulated head's Maestro (``facesynth simhead``), an SSC-32
on a pty; a silent port gives up fast, a port a program holds is not touched; nothing moves."""

from __future__ import annotations

import os
import time
import tty
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import serial

from facesynth.app.cli import main
from facesynth.app.doctor.needs import SerialNeed
from facesynth.app.doctor.serial_ports import (
    PortResult,
    ports_to_probe,
    probe_port,
    probe_ports,
    serial_findings,
)
from facesynth.app.firmware import bundled_version
from facesynth.services.control.drivers.arduino import protocol as proto

#: Doctor's own options that keep it to the part under test: its router on a port nobody
#: uses, and the record file in the test's folder.
QUIET = ["--listen", "tcp/127.0.0.1:0", "--log-level", "WARNING"]


@pytest.fixture
def silent(tmp_path: Path) -> Iterator[Path]:
    """A pty nothing answers on, at ``tmp_path/ttySilent``."""
    master, slave = os.openpty()
    tty.setraw(slave)
    link = tmp_path / "ttySilent"
    link.symlink_to(os.ttyname(slave))
    yield link
    os.close(master)
    os.close(slave)


def doctor(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, list[str], str]:
    code = main(["doctor", *argv, *QUIET])
    captured = capsys.readouterr()
    return code, captured.out.splitlines(), captured.err


def line_about(lines: list[str], family: str, text: str) -> str:
    """The one line of ``family`` that mentions ``text``, its spacing made single."""
    found = [" ".join(line.split()) for line in lines if line.split()[1:2] == [family]]
    found = [line for line in found if text in line]
    assert len(found) == 1, lines
    return found[0]


@pytest.mark.slow
def test_our_firmware_on_the_emulated_uno_answers_and_nothing_moves(
    uno: Any, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    pulses = uno.pulses()
    code, lines, err = doctor(
        ["--driver", "arduino", "--port", str(uno.port), "--profile", "paper16"], capsys
    )
    assert code == 0, err
    version = ".".join(map(str, bundled_version()))
    port = line_about(lines, "serial", str(uno.port))
    assert port.startswith("ok ")
    assert f"facesynth firmware {version} (protocol 1, 16 channels, pca9685 output)" in port
    assert line_about(lines, "firmware", str(uno.port)).endswith(
        f"firmware {version}, as bundled ({version})"
    )
    assert lines[-1].startswith("graph demo can run on this host")
    assert {frame.code for frame in uno.commands()} == {proto.COMMANDS["PING"].code}
    assert uno.pulses() == pulses  # no servo moved


@pytest.mark.slow
def test_the_simulated_heads_maestro_and_camera(
    simhead: tuple[Path, str],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    link, camera = simhead
    monkeypatch.chdir(tmp_path)
    code, lines, err = doctor(["--camera", camera, "--serial", str(link)], capsys)
    assert code == 0, err
    assert line_about(lines, "serial", str(link)) == (
        f"ok serial {link}: Pololu Maestro (errors: none): use --driver maestro"
    )
    assert line_about(lines, "camera", camera) == (
        f"ok camera {camera} (sensor node sensor): opens, 320x320"
    )


def test_an_ssc32_answers_ver_and_is_not_moved(ssc32: Any) -> None:
    result = probe_port(str(ssc32.link))
    assert result.answer is not None and result.answer.kind == "ssc32"
    assert result.answer.description == "Lynxmotion SSC-32 (SSC32-V2.50USB)"
    assert ssc32.moves == [] and ssc32.widths == {}
    assert ssc32.queries == ["VER"]


def test_a_board_other_than_the_graphs_is_one_line_to_fix(
    ssc32: Any, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    code, lines, err = doctor(
        ["--driver", "maestro", "--port", str(ssc32.link), "--profile", "paper16"], capsys
    )
    assert code == 2
    assert line_about(lines, "serial", str(ssc32.link)) == (
        f"fix serial {ssc32.link} (control node control, maestro): Lynxmotion SSC-32 "
        "(SSC32-V2.50USB) answers, not what the maestro driver drives: use --driver ssc32 for "
        "this port, or give the right --port"
    )
    assert err.strip().endswith(
        f"facesynth doctor: error: graph demo cannot run on this host: 1 thing to fix (serial "
        f"{ssc32.link} (control node control, maestro)), said above"
    )


def test_a_silent_port_gives_up_fast(silent: Path) -> None:
    started = time.monotonic()
    result = probe_port(str(silent))
    took = time.monotonic() - started
    assert result.answer is None and result.problem is None
    assert took < 2.0, took  # 0.3 + 0.5 + 0.4 s of questions


def test_a_port_in_use_is_not_touched(ssc32: Any) -> None:
    with serial.Serial(str(ssc32.link), exclusive=True):
        result = probe_port(str(ssc32.link))
    assert result.problem is not None and "in use by another program" in result.problem
    assert ssc32.queries == []


def test_ports_are_asked_at_once_and_judged_by_the_graph(ssc32: Any, silent: Path) -> None:
    started = time.monotonic()
    results = probe_ports(
        [
            (str(silent), 115200, False),
            (str(ssc32.link), 115200, False),
            ("/nonexistent", 9600, False),
        ]
    )
    assert time.monotonic() - started < 2.0  # in parallel, not one after the other
    needed = [SerialNeed("c", "ssc32", str(silent), 115200), SerialNeed("d", "maestro", "", 0)]
    statuses = [(f.status.value, f.subject) for f in serial_findings(results, needed)]
    assert statuses == [
        ("fix", "control node d"),
        ("fix", f"{silent} (control node c, ssc32)"),
        ("ok", str(ssc32.link)),
        ("info", "/nonexistent"),
    ]


def test_built_in_uarts_are_asked_only_when_named() -> None:
    """A login prompt on a serial console must not be typed at: listed ports that are not USB
    are asked only when the graph or --serial names them."""
    listed = [("/dev/ttyS0", False), ("/dev/ttyACM0", True), ("/dev/ttyAMA0", False)]
    needed = [SerialNeed("c", "maestro", "/dev/ttyAMA0", 9600, True)]
    asked, unasked = ports_to_probe(needed, ["/tmp/tty-x"], listed)
    assert asked == [
        ("/dev/ttyAMA0", 9600, True),
        ("/tmp/tty-x", 115200, False),
        ("/dev/ttyACM0", 115200, False),
    ]
    assert unasked == ["/dev/ttyS0"]
    (finding,) = serial_findings([PortResult("/dev/ttyS0", unasked=True)], [])
    assert finding.line() == (
        "info serial   /dev/ttyS0: a built-in serial port, not asked (a serial console may "
        "listen there): facesynth doctor --serial /dev/ttyS0 asks it"
    )
