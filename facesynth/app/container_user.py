"""The images' entry point: run ``facesynth`` as the owner of the clone it was started from.

A container made by ``docker-compose up`` mounts the clone's ``deploy`` folder at
``/etc/facesynth`` and its ``recordings`` folder at ``/recordings``. The image starts as root,
only to step down here, before anything else runs, to the owner of that mounted ``deploy``
folder: recordings then land in the clone owned by the user who cloned it, and certificates
that user made (``facesynth certs``, keys readable by their owner only) can be read, with no
``chown`` and no variable first. It holds on every engine: rootful Docker or Podman show the
folder with the user's own uid; rootless ones map the user to the container's root, so the
folder shows as root's and the command stays root inside, which is the user outside.

Without the mount (``docker run`` of the image alone) the command runs as the image's own
unprivileged user, 10001. Started as another user already (``--user``), it runs as is.
Supplementary groups the engine added (``group_add``: a serial device's group) are kept.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Sequence
from pathlib import Path

#: Where compose mounts the clone's deploy folder (facesynth.app.compose.MOUNT).
DEPLOY_MOUNT = Path("/etc/facesynth")
#: The image's own unprivileged user and group, when nothing is mounted.
IMAGE_USER = (10001, 10001)


def service_user(deploy: Path | None = None) -> tuple[int, int]:
    """The uid and gid to run as: the owner of the mounted deploy folder (``deploy``, default
    :data:`DEPLOY_MOUNT`), else 10001's."""
    try:
        status = (deploy or DEPLOY_MOUNT).stat()
    except FileNotFoundError:
        return IMAGE_USER
    return status.st_uid, status.st_gid


def step_down(uid: int, gid: int) -> None:
    """Become ``uid``:``gid`` for good (root only), keeping the engine's added groups but
    root's group."""
    groups = sorted({group for group in os.getgroups() if group != 0} - {gid})
    os.setgroups([gid, *groups])
    os.setgid(gid)
    os.setuid(uid)


def main(argv: Sequence[str] | None = None) -> int:
    """Step down to the clone owner (when started as root), then run the facesynth command."""
    args = list(sys.argv[1:] if argv is None else argv)
    if os.geteuid() == 0:
        uid, gid = service_user()
        whose = f"the owner of {DEPLOY_MOUNT}" if DEPLOY_MOUNT.exists() else "the image's own user"
        if uid != 0:
            step_down(uid, gid)
        if args[:1] != ["health"]:  # the health check runs every 15 s: not in every log
            print(f"facesynth container: running as {uid}:{gid}, {whose}", file=sys.stderr)
    from facesynth.app.entry import main as facesynth

    return facesynth(args)


if __name__ == "__main__":
    from facesynth.app.entry import run

    run(main)
