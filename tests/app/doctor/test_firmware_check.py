"""facesynth.app.doctor.firmware_check and facesynth.app.firmware.bundled_version: the firmware
on a board against the one in firmware/."""

from __future__ import annotations

from pathlib import Path

import pytest

from facesynth.app.doctor.boards import Answer
from facesynth.app.doctor.firmware_check import firmware_findings
from facesynth.app.doctor.needs import SerialNeed
from facesynth.app.doctor.serial_ports import PortResult
from facesynth.app.firmware import FirmwareError, bundled_version


def board(port: str, version: tuple[int, int, int], protocol: int = 1) -> PortResult:
    return PortResult(port, Answer("firmware", "facesynth firmware", version, protocol))


def test_the_bundled_version_is_read_from_the_sources(tmp_path: Path) -> None:
    major, minor, patch = bundled_version()
    header = Path(__file__).resolve().parents[3] / "firmware" / "facesynth_servo" / "device.h"
    text = header.read_text()
    assert all(
        f"#define FS_FIRMWARE_{part} {value}" in text
        for part, value in zip(("MAJOR", "MINOR", "PATCH"), (major, minor, patch), strict=True)
    )
    (tmp_path / "facesynth_servo").mkdir()
    (tmp_path / "Makefile").touch()
    with pytest.raises(FirmwareError, match="cannot read"):
        bundled_version(str(tmp_path))
    (tmp_path / "facesynth_servo" / "device.h").write_text("#define FS_FIRMWARE_MAJOR 1\n")
    with pytest.raises(FirmwareError, match="does not define FS_FIRMWARE_MAJOR, _MINOR and _PATCH"):
        bundled_version(str(tmp_path))
    with pytest.raises(FirmwareError, match="no firmware sources"):
        bundled_version(str(tmp_path / "nowhere"))


def test_each_board_against_the_bundled_firmware() -> None:
    results = [
        board("/dev/a", (0, 1, 0)),
        board("/dev/b", (0, 0, 9)),
        board("/dev/c", (2, 0, 0), protocol=2),
        board("/dev/d", (2, 0, 0), protocol=2),
        PortResult("/dev/e", Answer("maestro", "Pololu Maestro (errors: none)")),
        PortResult("/dev/f"),
    ]
    needed = [SerialNeed("control", "arduino", "/dev/c", 115200)]
    lines = [f.line() for f in firmware_findings(results, needed, (0, 1, 0))]
    assert lines == [
        "ok   firmware /dev/a: firmware 0.1.0, as bundled (0.1.0)",
        "info firmware /dev/b: firmware 0.0.9 on the board, 0.1.0 bundled (same protocol 1: it "
        "works); to update: facesynth firmware flash --port /dev/b",
        "fix  firmware /dev/c: firmware 2.0.0 speaks protocol 2, this facesynth speaks 1: flash "
        "the bundled firmware (0.1.0): facesynth firmware flash --port /dev/c",
        "note firmware /dev/d: firmware 2.0.0 speaks protocol 2, this facesynth speaks 1: flash "
        "the bundled firmware (0.1.0): facesynth firmware flash --port /dev/d",
    ]
    unknown = firmware_findings([board("/dev/a", (0, 1, 0))], [], None)
    assert [f.line() for f in unknown] == [
        "ok   firmware /dev/a: firmware 0.1.0, as bundled (unknown)"
    ]
