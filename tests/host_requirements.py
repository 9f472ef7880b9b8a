"""What each test group needs of the host, as data: a command on the PATH (or a file, by its
absolute path) and the Debian package that provides it.

The groups fail, never skip, naming the missing packages and the make target that installs
them (each target runs ``tools/system-packages.sh`` for its group first);
``tests/test_system_packages.py`` checks that every package named here is in that installer's
list for its group.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Sequence

import pytest

#: The servo firmware's build and the simavr harness (tests/firmware, the arduino driver's
#: tests), and avrdude for ``facesynth firmware flash``: part of ``make test``.
FIRMWARE_NEEDS: tuple[tuple[str, str], ...] = (
    ("make", "make"),
    ("gcc", "gcc"),
    ("avr-gcc", "gcc-avr"),
    ("avr-g++", "gcc-avr"),
    ("avr-objcopy", "binutils-avr"),
    ("avr-size", "binutils-avr"),
    ("/usr/lib/avr/include/avr/io.h", "avr-libc"),
    ("/usr/share/arduino/hardware/arduino/avr/cores/arduino/Arduino.h", "arduino-core-avr"),
    ("/usr/include/simavr/sim_avr.h", "libsimavr-dev"),
    ("/usr/include/libelf.h", "libelf-dev"),
    ("avrdude", "avrdude"),
)

#: Each group's needs, by the group's name in tools/system-packages.txt.
HOST_NEEDS: dict[str, tuple[tuple[str, str], ...]] = {
    "test": FIRMWARE_NEEDS,
    "browser": (("/usr/bin/chromium", "chromium"), ("/usr/bin/chromedriver", "chromium-driver")),
    "fuzz": (("gcc", "gcc"),),
    "faults": (),
    "ros2": (("unshare", "util-linux"), ("ip", "iproute2")),
    "board": (("systemd-analyze", "systemd"),),
    "netns": (("ip", "iproute2"), ("iptables", "iptables"), ("unshare", "util-linux")),
    "containers": (
        ("podman", "podman"),
        ("runc", "runc"),
        ("docker-compose", "docker-compose"),
        ("debootstrap", "debootstrap"),
        ("newuidmap", "uidmap"),
        ("slirp4netns", "slirp4netns"),
        ("fuse-overlayfs", "fuse-overlayfs"),
        ("iptables", "iptables"),
    ),
    "arm64": (
        ("podman", "podman"),
        ("runc", "runc"),
        ("debootstrap", "debootstrap"),
        ("arch-test", "arch-test"),
        ("qemu-aarch64-static", "qemu-user-static"),
        ("update-binfmts", "binfmt-support"),
    ),
}

#: The make target that installs a group's packages, then runs it.
MAKE_TARGET = {
    "test": "test",
    "browser": "test",
    "fuzz": "test-fuzz",
    "faults": "test-faults",
    "ros2": "test-ros2",
    "board": "test-board",
    "netns": "test-netns",
    "containers": "test-containers",
    "arm64": "test-arm64",
}


def _found(thing: str) -> bool:
    return os.path.exists(thing) if thing.startswith("/") else shutil.which(thing) is not None


def missing_packages(needs: Sequence[tuple[str, str]]) -> list[str]:
    """The Debian packages of ``needs`` whose command or file this host lacks, once each."""
    missing: list[str] = []
    for thing, package in needs:
        if not _found(thing) and package not in missing:
            missing.append(package)
    return missing


def install_hint(group: str, packages: Sequence[str]) -> str:
    """How to get ``packages``: the group's make target installs them (as root)."""
    return (
        f"make {MAKE_TARGET[group]} installs them as root (tools/system-packages.sh {group}); "
        f"or apt-get install {' '.join(packages)}"
    )


def require_packages(what: str, group: str, needs: Sequence[tuple[str, str]] = ()) -> None:
    """Fail the tests described by ``what`` (e.g. "the firmware tests") naming the Debian
    packages of ``needs`` (default: the group's whole table) this host lacks."""
    missing = missing_packages(needs or HOST_NEEDS[group])
    if missing:
        pytest.fail(
            f"{what} need the Debian package(s) {' '.join(missing)}: "
            f"{install_hint(group, missing)}",
            pytrace=False,
        )


def require_root_and_tools(what: str, group: str, root_for: str) -> None:
    """Fail the ``group`` tests (``what``, e.g. "the container tests") naming the packages of
    the group's table this host lacks, or when not root (they need it ``root_for``)."""
    require_packages(what, group)
    if os.geteuid() != 0:
        pytest.fail(f"{what} {root_for}: run them as root")
