"""What the deployment test groups (containers, netns, arm64) need of the host: tools on the
PATH and root. They fail, never skip, and say what is missing and how to install it."""

from __future__ import annotations

import os
import shutil
from collections.abc import Sequence

import pytest


def require_root_and_tools(group: str, tools: Sequence[str], install: str, root_for: str) -> None:
    """Fail the ``group`` tests (e.g. "the container tests") naming the ``tools`` not on the
    PATH, with ``install`` (how to get them), or when not root (they need it ``root_for``)."""
    missing = [tool for tool in tools if shutil.which(tool) is None]
    if missing:
        pytest.fail(f"{group} need {', '.join(missing)} ({install})")
    if os.geteuid() != 0:
        pytest.fail(f"{group} {root_for}: run them as root")
