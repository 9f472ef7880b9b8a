"""facesynth.runtime.clock_host: the name a process's stamps carry is its kernel's, not its host
name's, so containers on one machine (hostnames of their own, one clock) share it and other
machines (another boot id) do not."""

from __future__ import annotations

import socket
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from facesynth.runtime.clock_host import BOOT_ID, clock_host, clock_name, read_boot_id
from facesynth.services.sensor.sources.ros2_images import stamp_clock

BOOT = "ba04dc09-2d79-401b-953b-26d5b0cf640f\n"  # as the kernel writes it
OTHER = "ba04dc09-5e11-4c1e-8a2b-0f3e2d1c4b5a\n"  # another machine's (the same first 8 digits)


def test_processes_of_one_kernel_share_the_name_whatever_their_host_names() -> None:
    # Two containers of one machine: hostnames of their own, the machine's boot id.
    assert (
        clock_name(BOOT, "sensor-7f3a") == clock_name(BOOT, "control-19bc") == "boot:ba04dc092d79"
    )


def test_other_machines_and_reboots_have_other_names() -> None:
    assert clock_name(OTHER, "rig") != clock_name(BOOT, "rig")  # same host name, other kernel
    assert clock_name(BOOT.upper(), "a") == clock_name(BOOT, "b")  # one id, however written


@pytest.mark.parametrize(
    "boot_id",
    [None, "", "\n", "not-a-boot-id", "ba04dc09-2d79-401b-953b", BOOT.strip() + "00", "é" * 36],
    ids=["unreadable", "empty", "newline", "words", "short", "long", "non-ascii"],
)
def test_without_a_boot_id_the_host_name_is_the_name(boot_id: str | None) -> None:
    assert clock_name(boot_id, "mac-mini") == "mac-mini"
    assert clock_name(boot_id, "") == "host"  # never empty: empty means "not aged"


def test_a_kernels_name_is_never_a_host_name_nor_a_cameras_clock() -> None:
    name = clock_name(BOOT, "h")
    assert ":" in name and ":" not in socket.gethostname()  # host names have no colon
    assert name != stamp_clock("/camera/image_raw") and stamp_clock("/a") != stamp_clock("/b")


def test_the_boot_id_is_read_or_none(tmp_path: Path) -> None:
    (tmp_path / "boot_id").write_text(BOOT)
    assert read_boot_id(tmp_path / "boot_id") == BOOT
    assert read_boot_id(tmp_path / "missing") is None
    assert read_boot_id(tmp_path) is None  # a folder: unreadable


def test_this_process_is_named_by_its_kernel_and_its_children_alike() -> None:
    assert clock_host() == clock_name(read_boot_id(), socket.gethostname())
    if sys.platform == "linux":
        assert BOOT_ID.exists() and clock_host().startswith("boot:")
    child = subprocess.run(
        [
            sys.executable,
            "-c",
            "from facesynth.runtime.clock_host import clock_host as c; print(c())",
        ],
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    )
    assert child.stdout.strip() == clock_host()


@given(
    st.one_of(st.none(), st.text(max_size=80), st.uuids().map(str)),
    st.text(max_size=40).filter(lambda h: ":" not in h),
)
def test_any_boot_id_file_names_a_kernel_or_falls_back_never_empty(
    boot_id: str | None, hostname: str
) -> None:
    # Whatever the file holds: a kernel's name exactly for a UUID, else the host name.
    name = clock_name(boot_id, hostname)
    assert name
    if name.startswith("boot:"):
        digits = name.removeprefix("boot:")
        assert boot_id is not None and len(digits) == 12
        assert boot_id.strip().lower().replace("-", "").startswith(digits)
    else:
        assert name == (hostname or "host")
