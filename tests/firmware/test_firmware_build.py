"""The firmware's host unit tests (gcc, ASan/UBSan) and its fit on an Arduino Uno."""

from __future__ import annotations

import re
import subprocess

import pytest
from uno_emulator import FIRMWARE

pytestmark = pytest.mark.firmware


def test_host_unit_tests_pass(firmware_build: str) -> None:
    result = subprocess.run(
        ["make", "-C", str(FIRMWARE), "host-test"], capture_output=True, text=True, check=False
    )
    summary = re.search(r"^(\d+) passed, (\d+) failed$", result.stdout, re.MULTILINE)
    assert result.returncode == 0 and summary, result.stdout + result.stderr
    assert int(summary[1]) > 100 and summary[2] == "0"


SIZE_LINE = re.compile(
    r"build/(\w+)/facesynth_servo\.elf: flash (\d+) / \d+ bytes, RAM \(data\+bss\) (\d+) / \d+"
)


def test_both_variants_fit_an_uno(firmware_build: str) -> None:
    """``make build`` reports flash and RAM per variant (and fails itself above the Uno's)."""
    variants = {
        name: (int(flash), int(ram)) for name, flash, ram in SIZE_LINE.findall(firmware_build)
    }
    assert set(variants) == {"pca9685", "pins"}, firmware_build
    for flash, ram in variants.values():
        assert flash <= 32256  # 32 KiB minus the 512-byte bootloader
        assert ram <= 1536  # static RAM, leaving at least 512 of the 2048 bytes for the stack
