"""Helpers for the container tests: the engine's environment, free ports, project names."""

from __future__ import annotations

import socket
import subprocess
import uuid
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from host_requirements import require_root_and_tools

ROOT = Path(__file__).resolve().parents[2]
#: The user whose clone the tests run compose in: an ordinary first user, neither root nor the
#: image's own 10001.
CLONE_USER = (1000, 1000)


def require() -> None:
    """Fail (never skip) with the missing packages named, or when not root."""
    require_root_and_tools("the container tests", "containers", "run a rootful Podman")


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@dataclass
class Engine:
    """Podman's Docker API on a private socket, and the environment compose needs."""

    env: dict[str, str]

    def run(
        self,
        *argv: str,
        cwd: Path | None = None,
        timeout: float = 600,
        check: bool = True,
        variables: Mapping[str, str] | None = None,
    ) -> subprocess.CompletedProcess[str]:
        """Run ``argv`` against the engine, with ``variables`` added to the environment."""
        result = subprocess.run(
            list(argv),
            cwd=cwd,
            env={**self.env, **(variables or {})},
            capture_output=True,
            text=True,
            timeout=timeout,
        )
        if check and result.returncode != 0:
            raise AssertionError(
                f"{' '.join(argv)} failed ({result.returncode}):\n"
                f"{result.stdout[-3000:]}\n{result.stderr[-3000:]}"
            )
        return result


def project_name() -> str:
    """A compose project name no other run uses."""
    return f"fs{uuid.uuid4().hex[:8]}"
