"""The ROS 2 group's own checks: it runs with only loopback, and says so when it does not."""

from __future__ import annotations

import os

from conftest import interfaces, loopback_only_problem


def test_this_namespace_has_only_loopback_up() -> None:
    assert interfaces() == {"lo": True}
    assert os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"


def test_another_interface_or_loopback_down_is_refused() -> None:
    assert loopback_only_problem({"lo": True}) is None
    assert "has eth0: run them with make test-ros2" in str(
        loopback_only_problem({"lo": True, "eth0": True})
    )
    assert "loopback is down" in str(loopback_only_problem({"lo": False}))
