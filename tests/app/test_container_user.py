"""The images' entry point runs facesynth as the owner of the mounted deploy folder."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from facesynth.app import container_user
from facesynth.app.compose import MOUNT
from facesynth.app.container_user import IMAGE_USER, service_user

ROOT = Path(__file__).resolve().parents[2]

#: Run in a child: point the entry at FOLDER, start as root with groups 0 and 20 (as an engine
#: gives root plus a group_add), run the entry with a command that prints who runs it. (Not
#: facesynth itself: this interpreter's standard library may lie in root's home, out of reach
#: after stepping down; the container tests run the real commands in the image.)
CHILD = """
import os, sys
from pathlib import Path
from facesynth.app import container_user, entry
container_user.DEPLOY_MOUNT = Path(sys.argv[1])
if os.geteuid() == 0:
    os.setgroups([0, 20])
def command(argv):
    print(len(argv), os.getuid(), os.getgid(), sorted(os.getgroups()))
    return 0
entry.main = command
sys.exit(container_user.main(["control", "--help"]))
"""


def _child(folder: Path) -> tuple[list[str], str]:
    result = subprocess.run(
        [sys.executable, "-c", CHILD, str(folder)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 0, result.stderr
    return result.stdout.splitlines()[-1].split(" ", 3), result.stderr


def test_the_user_is_the_owner_of_the_deploy_folder(tmp_path: Path) -> None:
    status = tmp_path.stat()
    assert service_user(tmp_path) == (status.st_uid, status.st_gid)


def test_without_the_mount_the_user_is_the_images_own() -> None:
    assert service_user(Path("/nonexistent/deploy")) == IMAGE_USER == (10001, 10001)


def test_the_entry_looks_where_compose_mounts_the_deploy_folder() -> None:
    assert str(container_user.DEPLOY_MOUNT) == MOUNT


def test_root_steps_down_to_the_folders_owner_keeping_added_groups(tmp_path: Path) -> None:
    deploy = tmp_path / "deploy"
    deploy.mkdir()
    if os.geteuid() != 0:  # not root: nothing to step down from, the command runs as is
        (status, uid, gid, groups), _ = _child(deploy)
        assert (status, int(uid), int(gid)) == ("2", os.getuid(), os.getgid())
        return
    os.chown(deploy, 1234, 2345)
    (status, uid, gid, groups), stderr = _child(deploy)
    assert (status, uid, gid) == ("2", "1234", "2345")
    assert groups == "[20, 2345]", "root's group dropped, the engine's group_add kept"
    assert f"running as 1234:2345, the owner of {deploy}" in stderr


def test_a_folder_owned_by_root_keeps_root(tmp_path: Path) -> None:
    """Rootless engines show the user's own folder as root's: root inside is the user."""
    (status, uid, gid, _groups), _ = _child(tmp_path)
    assert (status, int(uid), int(gid)) == ("2", os.getuid(), tmp_path.stat().st_gid)
