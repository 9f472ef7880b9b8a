"""The test groups' Debian packages: every package a group's tests ask for is in the installer's
list for that group (tools/system-packages.txt), each group's make target installs its own
first, and .ci/run calls those targets, starting with the README's test command."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

import pytest
from host_requirements import FIRMWARE_NEEDS, HOST_NEEDS, MAKE_TARGET

from facesynth.app import firmware

ROOT = Path(__file__).resolve().parents[1]
INSTALLER = ROOT / "tools" / "system-packages.sh"


def installer_lists(path: Path = ROOT / "tools" / "system-packages.txt") -> dict[str, set[str]]:
    """The installer's packages by group."""
    groups: dict[str, set[str]] = {}
    for line in path.read_text().splitlines():
        if line.strip() and not line.startswith("#"):
            group, _, packages = line.partition(":")
            groups[group.strip()] = set(packages.split())
    return groups


@pytest.mark.parametrize("group", sorted(HOST_NEEDS))
def test_every_package_a_group_asks_for_is_in_its_installer_list(group: str) -> None:
    asked = {package for _, package in HOST_NEEDS[group]}
    listed = installer_lists().get(group)
    assert listed is not None, f"tools/system-packages.txt has no line for the {group} group"
    assert asked <= listed, f"{group}: not in the installer's list: {sorted(asked - listed)}"


def test_the_firmware_command_names_only_packages_the_tests_install() -> None:
    named = {package for _, package in firmware._BUILD_NEEDS} | {"avrdude"}
    assert named <= {package for _, package in FIRMWARE_NEEDS}
    assert named <= installer_lists()["test"]


def test_every_marked_group_has_its_needs_declared() -> None:
    text = (ROOT / "pyproject.toml").read_text()
    markers = set(re.findall(r'^\s*"(\w+): ', text, flags=re.M))
    for group in ("browser", "containers", "netns", "board", "faults", "fuzz", "arm64"):
        assert group in markers, group
        assert group in HOST_NEEDS, f"tests/host_requirements.py declares nothing for {group}"


@pytest.mark.parametrize("group", sorted(MAKE_TARGET))
def test_each_group_make_target_installs_its_packages_first(group: str) -> None:
    if shutil.which("make") is None:
        pytest.fail("make is missing")
    target = MAKE_TARGET[group]
    # As from a shell: not as part of the make that may be running these tests.
    env = {k: v for k, v in os.environ.items() if k not in ("MAKEFLAGS", "MFLAGS", "MAKELEVEL")}
    dry = subprocess.run(
        ["make", "-n", "--no-print-directory", target],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
        env=env,
    )
    assert dry.returncode == 0, dry.stderr
    lines = dry.stdout.splitlines()
    installs = [i for i, line in enumerate(lines) if "tools/system-packages.sh" in line]
    assert any(group in lines[i].split() for i in installs), dry.stdout
    runs = [i for i, line in enumerate(lines) if "pytest" in line]
    assert runs and installs and min(installs) < min(runs), dry.stdout


def test_ci_runs_the_readme_test_command_and_every_group() -> None:
    ci = (ROOT / ".ci" / "run").read_text()
    readme = (ROOT / "README.md").read_text()
    quick_start = readme.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    assert re.search(r"^make test\b", quick_start, flags=re.M)
    assert re.search(r"^make test$", ci, flags=re.M)
    for target in set(MAKE_TARGET.values()) - {"test"}:
        assert target in ci, f".ci/run does not run make {target}"
    # The packages are the make targets' business: .ci/run installs make alone, if at all.
    for line in ci.splitlines():
        if "apt-get install" in line and not line.lstrip().startswith("#"):
            words = line.split("apt-get install", 1)[1].split()
            assert [w for w in words if not w.startswith("-")] == ["make"], line


def _installer(*args: str, env: dict[str, str], user: bool = False) -> subprocess.CompletedProcess:
    command = ["bash", str(INSTALLER), *args]
    if user:
        command = ["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups", *command]
    return subprocess.run(command, capture_output=True, text=True, timeout=60, env=env)


def test_nothing_missing_is_silent(tmp_path: Path) -> None:
    listed = tmp_path / "packages.txt"
    listed.write_text("# a group whose packages every Debian has\nbase: bash coreutils\n")
    done = _installer("base", env={**os.environ, "FACESYNTH_SYSTEM_PACKAGES": str(listed)})
    assert (done.returncode, done.stdout, done.stderr) == (0, "", "")


def test_not_root_gets_one_line_naming_the_packages(tmp_path: Path) -> None:
    if os.geteuid() != 0 or shutil.which("setpriv") is None:
        pytest.fail("this test runs the installer as another user: it needs root and setpriv")
    # Where the other user can read it (pytest's own folders are root's alone).
    listed = Path(tempfile.mkdtemp(prefix="facesynth-packages-")) / "packages.txt"
    listed.parent.chmod(0o755)
    listed.write_text("base: bash facesynth-no-such-package\n")
    try:
        done = _installer(
            "base", env={**os.environ, "FACESYNTH_SYSTEM_PACKAGES": str(listed)}, user=True
        )
    finally:
        shutil.rmtree(listed.parent)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1, done.stderr
    assert "facesynth-no-such-package: run as root" in done.stderr
    assert "sudo apt-get install facesynth-no-such-package" in done.stderr


def test_an_unknown_group_is_one_line(tmp_path: Path) -> None:
    done = _installer("nosuchgroup", env=dict(os.environ))
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "no group 'nosuchgroup'" in done.stderr
