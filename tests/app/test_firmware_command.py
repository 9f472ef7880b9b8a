"""``facesynth firmware build|flash``: the build through the firmware's Makefile, and a real
avrdude writing the HEX into a fake Uno bootloader (optiboot's STK500) on a pty."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "control"))

from fake_devices import optiboot
from fake_devices.optiboot import FakeOptiboot

from facesynth.app import firmware
from facesynth.app.cli import main

SOURCE = firmware.firmware_dir()


def intel_hex(path: Path) -> dict[int, int]:
    """Byte address -> value of an Intel HEX file (data records only)."""
    memory: dict[int, int] = {}
    for line in path.read_text().split():
        count, address, kind = int(line[1:3], 16), int(line[3:7], 16), int(line[7:9], 16)
        record = bytes.fromhex(line[1:])
        assert sum(record) & 0xFF == 0, f"bad checksum in {line}"
        if kind == 0:
            for i in range(count):
                memory[address + i] = record[4 + i]
    return memory


def test_the_avrdude_command(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["firmware", "flash", "--port", "/dev/ttyACM0", "--dry-run"]) == 0
    hex_file = SOURCE / "build" / "pca9685" / "facesynth_servo.hex"
    assert capsys.readouterr().out.strip() == (
        f"avrdude -p atmega328p -c arduino -P /dev/ttyACM0 -b 115200 -D -U flash:w:{hex_file}:i"
    )
    assert (
        main(
            [
                "firmware",
                "flash",
                "--port",
                "COM3",
                "--variant",
                "pins",
                "--baud",
                "57600",
                "--dry-run",
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    pins = SOURCE / "build" / "pins" / "facesynth_servo.hex"
    assert "-P COM3 -b 57600" in out and f"flash:w:{pins}:i" in out


@pytest.mark.firmware
def test_build_reports_flash_and_ram(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["firmware", "build", "--variant", "pins"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("build/pins/facesynth_servo.elf: flash ") and "/ 32256 bytes" in out[0]
    assert out[1] == str(SOURCE / "build" / "pins" / "facesynth_servo.hex")


@pytest.mark.firmware
def test_flash_writes_the_hex_through_the_bootloader(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    board = FakeOptiboot(tmp_path / "ttyACM0")
    board.plug()
    try:
        assert main(["firmware", "flash", "--port", str(board.link)]) == 0
    finally:
        board.close()
    out = capsys.readouterr().out
    assert "bytes of flash written" in out and "bytes of flash verified" in out
    image = intel_hex(SOURCE / "build" / "pca9685" / "facesynth_servo.hex")
    assert len(image) > 8000 and board.left_programming
    assert all(board.flash[address] == value for address, value in image.items())


@pytest.mark.firmware
def test_a_failed_flash_is_one_clear_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(optiboot, "SIGNATURE", bytes([0x1E, 0x95, 0x14]))  # an ATmega328 (no P)
    board = FakeOptiboot(tmp_path / "ttyACM0")
    board.plug()
    try:
        assert main(["firmware", "flash", "--port", str(board.link)]) == 2
    finally:
        board.close()
    err = capsys.readouterr().err
    assert err.startswith("facesynth firmware: error: avrdude failed (exit 1): ")
    assert "signature" in err and len(err.strip().splitlines()) == 1 and board.pages_written == 0


def test_missing_tools_are_named(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv("PATH", str(tmp_path))  # no make, no avr-gcc, no avrdude
    assert main(["firmware", "build"]) == 2
    err = capsys.readouterr().err
    assert "building the firmware needs the Debian package(s) make gcc-avr binutils-avr" in err
    hex_file = tmp_path / "f.hex"
    hex_file.write_text(":00000001FF\n")
    assert main(["firmware", "flash", "--port", "/dev/ttyACM0", "--hex", str(hex_file)]) == 2
    assert "flashing needs avrdude (Debian package avrdude)" in capsys.readouterr().err


def test_no_sources(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["firmware", "build", "--firmware-dir", str(tmp_path)]) == 2
    assert f"no firmware sources in {tmp_path}" in capsys.readouterr().err
