"""``facesynth firmware build|flash``: the Uno servo firmware (``firmware/``) for users.

``build`` runs the firmware's Makefile (Debian's ``gcc-avr``, ``avr-libc`` and
``arduino-core-avr``; no Arduino IDE) and prints the flash and RAM use; ``flash`` writes the
HEX to an Uno through its bootloader with ``avrdude`` (building it first if needed).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
from pathlib import Path

#: The two builds: 16 servos on a PCA9685 board, or 12 on pins D2..D13.
VARIANTS = ("pca9685", "pins")
#: The Uno's bootloader (optiboot) speaks STK500 at this rate.
BOOTLOADER_BAUD = 115200
ARDUINO_CORE = Path("/usr/share/arduino/hardware/arduino/avr/cores/arduino/Arduino.h")

# What a build needs, and the Debian package that provides it.
_BUILD_NEEDS: tuple[tuple[str, str], ...] = (
    ("make", "make"),
    ("avr-gcc", "gcc-avr"),
    ("avr-g++", "gcc-avr"),
    ("avr-objcopy", "binutils-avr"),
    ("avr-size", "binutils-avr"),
    ("/usr/lib/avr/include/avr/io.h", "avr-libc"),
    (str(ARDUINO_CORE), "arduino-core-avr"),
)


class FirmwareError(ValueError):
    """The firmware cannot be built or flashed here; says what is missing."""


def firmware_dir(given: str | None = None) -> Path:
    """The firmware sources: ``given``, else ``$FACESYNTH_FIRMWARE``, else the checkout's."""
    path = Path(given or os.environ.get("FACESYNTH_FIRMWARE") or _checkout_firmware())
    if not (path / "Makefile").is_file() or not (path / "facesynth_servo").is_dir():
        raise FirmwareError(
            f"no firmware sources in {path}: run from a facesynth checkout or pass "
            "--firmware-dir DIR (the repository's firmware/ folder)"
        )
    return path


def _checkout_firmware() -> Path:
    return Path(__file__).resolve().parents[2] / "firmware"


#: Where the firmware's sources say its version (reported by PING).
VERSION_HEADER = Path("facesynth_servo") / "device.h"
_VERSION_LINE = re.compile(r"#define FS_FIRMWARE_(MAJOR|MINOR|PATCH) (\d+)")


def bundled_version(given: str | None = None) -> tuple[int, int, int]:
    """The version of the firmware sources (``firmware/facesynth_servo/device.h``), as PING
    reports it once flashed; :class:`FirmwareError` without sources."""
    header = firmware_dir(given) / VERSION_HEADER
    try:
        text = header.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise FirmwareError(f"cannot read {header}: {exc}") from None
    parts = dict(_VERSION_LINE.findall(text))
    if set(parts) != {"MAJOR", "MINOR", "PATCH"}:
        raise FirmwareError(f"{header} does not define FS_FIRMWARE_MAJOR, _MINOR and _PATCH")
    return int(parts["MAJOR"]), int(parts["MINOR"]), int(parts["PATCH"])


def missing_packages(needs: tuple[tuple[str, str], ...] = _BUILD_NEEDS) -> list[str]:
    """Debian packages whose programs or files are missing."""
    missing: list[str] = []
    for thing, package in needs:
        found = Path(thing).exists() if thing.startswith("/") else shutil.which(thing) is not None
        if not found and package not in missing:
            missing.append(package)
    return missing


def hex_path(source: Path, variant: str) -> Path:
    """Where ``make build`` puts a variant's HEX file."""
    return source / "build" / variant / "facesynth_servo.hex"


def build_command(source: Path, variant: str | None) -> list[str]:
    """``make`` for one variant (or both)."""
    command = ["make", "-C", str(source), "build"]
    if variant is not None:
        command.append(f"VARIANTS={variant}")
    return command


def build(source: Path, variant: str | None) -> str:
    """Build the firmware; returns make's report (flash and RAM use per variant)."""
    missing = missing_packages()
    if missing:
        raise FirmwareError(
            f"building the firmware needs the Debian package(s) {' '.join(missing)}: "
            f"sudo apt-get install {' '.join(missing)}"
        )
    result = subprocess.run(build_command(source, variant), capture_output=True, text=True)
    if result.returncode != 0:
        tail = "\n".join((result.stdout + result.stderr).strip().splitlines()[-15:])
        raise FirmwareError(f"the firmware build failed (make exit {result.returncode}):\n{tail}")
    return "\n".join(
        line for line in result.stdout.splitlines() if "flash" in line and "RAM" in line
    )


def avrdude_command(port: str, hex_file: Path, baud: int = BOOTLOADER_BAUD) -> list[str]:
    """The avrdude command that writes ``hex_file`` to an Uno through its bootloader."""
    return [
        "avrdude",
        "-p",
        "atmega328p",
        "-c",
        "arduino",
        "-P",
        port,
        "-b",
        str(baud),
        "-D",
        "-U",
        f"flash:w:{hex_file}:i",
    ]


def flash(port: str, hex_file: Path, baud: int = BOOTLOADER_BAUD) -> str:
    """Run avrdude; returns its last lines, raises :class:`FirmwareError` with them on failure."""
    if shutil.which("avrdude") is None:
        raise FirmwareError(
            "flashing needs avrdude (Debian package avrdude): sudo apt-get install avrdude"
        )
    result = subprocess.run(
        avrdude_command(port, hex_file, baud), capture_output=True, text=True, timeout=300
    )
    output = (result.stdout + result.stderr).strip().splitlines()
    if result.returncode != 0:
        errors = [
            line
            for line in output
            if "error" in line.lower() and "ioctl" not in line  # (modem lines on a pty)
        ]
        last = errors[-1] if errors else (output[-1] if output else "no output")
        raise FirmwareError(f"avrdude failed (exit {result.returncode}): {last.strip()}")
    return "\n".join(line for line in output if "bytes of flash" in line) or "flashed"


def add_firmware_arguments(parser: argparse.ArgumentParser) -> None:
    """``facesynth firmware build|flash`` options."""
    parser.add_argument("action", choices=("build", "flash"))
    parser.add_argument(
        "--variant",
        choices=(*VARIANTS, "all"),
        help="pca9685 (16 servos on a PCA9685 board; flash's default) or pins (12 servos on "
        "D2..D13); build's default: all",
    )
    parser.add_argument("--port", help="flash: the Uno's serial port, e.g. /dev/ttyACM0")
    parser.add_argument(
        "--baud",
        type=int,
        default=BOOTLOADER_BAUD,
        help=f"flash: the bootloader's baud rate (default {BOOTLOADER_BAUD}; old Unos: 57600)",
    )
    parser.add_argument("--hex", metavar="FILE", help="flash: this HEX file instead of a build")
    parser.add_argument(
        "--firmware-dir", metavar="DIR", help="the firmware sources (default: the checkout's)"
    )
    parser.add_argument(
        "--dry-run", action="store_true", help="flash: print the avrdude command, do not run it"
    )


def cmd_firmware(args: argparse.Namespace) -> int:
    """``facesynth firmware build|flash``."""
    if args.action == "build":
        if args.port or args.hex or args.dry_run:
            raise FirmwareError("--port, --hex and --dry-run are options of flash")
        source = firmware_dir(args.firmware_dir)
        variant = None if args.variant in (None, "all") else args.variant
        print(build(source, variant))
        for name in VARIANTS if variant is None else (variant,):
            print(hex_path(source, name))
        return 0
    if not args.port:
        raise FirmwareError("flash needs --port, e.g. --port /dev/ttyACM0")
    if args.variant == "all":
        raise FirmwareError("flash writes one variant: --variant pca9685 or pins")
    if args.hex:
        hex_file = Path(args.hex)
        if not hex_file.is_file():
            raise FirmwareError(f"{hex_file} does not exist")
    else:
        source = firmware_dir(args.firmware_dir)
        variant = args.variant or "pca9685"
        hex_file = hex_path(source, variant)
        if not args.dry_run and (not hex_file.is_file() or not missing_packages()):
            print(build(source, variant))  # make rebuilds only what changed
    command = avrdude_command(args.port, hex_file, args.baud)
    if args.dry_run:
        print(" ".join(command))
        return 0
    print(flash(args.port, hex_file, args.baud))
    return 0
