"""Whether rclpy imports here, which ROS 2 distribution and middleware (RMW) it would use, and
the discovery settings its nodes would start with (``facesynth doctor``).

Imported in the doctor's own process, only to read names: no node is started, nothing is sent.
A graph with a ``ros2`` driver or source needs it (a ``fix`` line when it fails); otherwise it
is a note when missing.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import os
import re
from collections.abc import Mapping

from facesynth.app.doctor.report import Finding

FAMILY = "ros2"
INSTALL = "pip install 'facesynth[ros2]'"
_DISTRO = re.compile(r"^ros-([a-z]+)-rclpy$")


def distributions() -> list[str]:
    """``jazzy 7.1.6``-style names of the ROS 2 rclpy wheels installed here."""
    found = []
    for dist in importlib.metadata.distributions():
        match = _DISTRO.match((dist.metadata["Name"] or "").lower())
        if match:
            found.append(f"{match.group(1)} {dist.version}")
    return sorted(set(found))


def discovery(environ: Mapping[str, str]) -> str:
    """The discovery settings a node would start with, in words (pure)."""
    domain = environ.get("ROS_DOMAIN_ID") or "0 (default)"
    reach = environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE") or "SUBNET (default)"
    return f"ROS_DOMAIN_ID {domain}, discovery range {reach}"


def ros2_findings(needed: bool, environ: Mapping[str, str] | None = None) -> list[Finding]:
    """One line: rclpy, its distribution and RMW, and the discovery settings."""
    env = os.environ if environ is None else environ
    try:
        importlib.import_module("rclpy")
        utilities = importlib.import_module("rclpy.utilities")
        rmw = str(utilities.get_rmw_implementation_identifier())
    except ImportError:
        return [Finding(FAMILY, "rclpy", "not installed", good=False, needed=needed, fix=INSTALL)]
    except Exception as exc:  # a broken install: a library or the middleware missing
        text = " ".join(str(exc).split()) or type(exc).__name__
        return [
            Finding(
                FAMILY,
                "rclpy",
                f"does not load ({text})",
                good=False,
                needed=needed,
                fix=f"reinstall it: {INSTALL}",
            )
        ]
    chosen = "RMW_IMPLEMENTATION" if env.get("RMW_IMPLEMENTATION") else "default"
    distro = ", ".join(distributions()) or "distribution unknown"
    return [
        Finding(
            FAMILY,
            "rclpy",
            f"imports (ROS 2 {distro}); RMW {rmw} ({chosen}); {discovery(env)}",
        )
    ]
