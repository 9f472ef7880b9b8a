"""facesynth.app.doctor.ros2: one line on rclpy (distribution, RMW, discovery settings); a fix
line when a ros2 plugin needs it and it is missing or broken, a note otherwise.

That it imports and names Fast DDS is checked where rclpy is installed: tests/ros2."""

from __future__ import annotations

import importlib
import sys

import pytest

from facesynth.app.doctor.report import Status
from facesynth.app.doctor.ros2 import discovery, ros2_findings


def test_discovery_settings_in_words() -> None:
    assert discovery({}) == "ROS_DOMAIN_ID 0 (default), discovery range SUBNET (default)"
    assert discovery({"ROS_DOMAIN_ID": "7", "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}) == (
        "ROS_DOMAIN_ID 7, discovery range LOCALHOST"
    )


@pytest.mark.parametrize(("needed", "status"), [(True, Status.FIX), (False, Status.NOTE)])
def test_rclpy_missing(needed: bool, status: Status, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "rclpy", None)
    (finding,) = ros2_findings(needed, {})
    assert finding.status is status
    assert finding.line(width=4) == (
        f"{status.value:<4} ros2 rclpy: not installed: pip install 'facesynth[ros2]'"
    )


def test_a_broken_rclpy_is_said_in_one_line(monkeypatch: pytest.MonkeyPatch) -> None:
    real = importlib.import_module

    def broken(name: str, *args: object) -> object:
        if name.startswith("rclpy"):
            raise RuntimeError("librmw_fastrtps_cpp.so:\n cannot open shared object file")
        return real(name, *args)  # type: ignore[arg-type]

    monkeypatch.setattr(importlib, "import_module", broken)
    (finding,) = ros2_findings(True, {})
    assert finding.status is Status.FIX
    assert finding.line(width=4) == (
        "fix  ros2 rclpy: does not load (librmw_fastrtps_cpp.so: cannot open shared object "
        "file): reinstall it: pip install 'facesynth[ros2]'"
    )
