"""facesynth.app.bench.device_host.DeviceHost: the one emulator process of ``bench drivers
--emulated`` and ``bench run``: it counts the bytes a driver sends, and an emulator that does
not start is one clear error."""

from __future__ import annotations

import contextlib
import os
import time
from pathlib import Path

import pytest

from facesynth.app.bench import run_compare
from facesynth.app.bench.device_host import DeviceHost, EmulatorStartError
from facesynth.app.bench.driver_cpu import FAKE_DEVICES


def test_the_host_counts_the_bytes_written_to_its_link(tmp_path: Path) -> None:
    link = tmp_path / "tty"
    with contextlib.closing(DeviceHost(FAKE_DEVICES, "maestro", link)) as host:
        fd = os.open(link, os.O_RDWR | os.O_NOCTTY)
        try:
            os.write(fd, bytes([0x84, 0, 0x70, 0x2E]))  # Set Target, channel 0, 1500 µs
            counts = host.count()
            for _ in range(100):  # the emulator's thread reads the pty when it can
                if counts[0]:
                    break
                time.sleep(0.02)
                counts = host.count()
        finally:
            os.close(fd)
        assert counts[:2] == (4, 0)
    assert host.proc.returncode == 0
    assert not link.exists()


def test_an_emulator_that_does_not_start_is_one_clear_error(tmp_path: Path) -> None:
    with pytest.raises(EmulatorStartError, match=r"the teleporter emulator did not start \(''\)"):
        DeviceHost(FAKE_DEVICES, "teleporter", tmp_path / "tty")


def test_bench_run_says_its_maestro_did_not_start(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def broken(parent: Path, kind: str, link: Path) -> DeviceHost:
        return DeviceHost(parent, "teleporter", link)

    monkeypatch.setattr(run_compare, "DeviceHost", broken)
    with (
        pytest.raises(run_compare.RunFailed, match="emulator did not start"),
        run_compare.maestro_on_a_pty(tmp_path),
    ):
        pass
