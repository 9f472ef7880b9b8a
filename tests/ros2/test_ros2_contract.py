"""The driver contract suite (tests/control/test_driver_contract.py) on the ``'ros2'`` driver,
read back by a real rclpy subscriber in another process: what is sent comes out (as radians
of the profile's angle maps), neutral, limits, refusals, connect and close, bad settings.

The subscriber is one process for the module (started once: 1-1.5 s a test otherwise, in the
module's ROS 2 domain), taking a topic of each test's own, so no test reads another's messages.
"""

from __future__ import annotations

import math
import sys
from collections.abc import AsyncIterator, Iterator, Mapping
from pathlib import Path
from typing import Any

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "control"))  # the suite
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "firmware"))  # its Uno rig

from driver_rigs import PAPER16, DriverRig
from ros2_peers import Received, read_received, subscriber
from test_driver_contract import (  # noqa: F401 - the suite's tests and fixture, run here
    session,
    test_async_with_connects_and_closes_even_when_the_block_fails,
    test_close_without_connect_is_harmless,
    test_connect_again_after_close,
    test_limits_come_out_as_limits,
    test_malformed_settings_are_refused_naming_the_field,
    test_neutral_puts_out_the_neutral_face,
    test_positions_outside_the_limits_never_come_out,
    test_send_before_connect_and_after_close_is_a_driver_error,
    test_settings_that_cannot_work_are_one_clear_line,
    test_the_last_of_many_commands_is_what_stays,
    test_unknown_servos_and_non_finite_positions_are_refused,
    test_what_is_sent_is_what_comes_out,
)

from facesynth.services.control.drivers.base import ServoDriver

#: A topic for each test (more than the suite has), all taken by the module's subscriber.
TOPICS = [f"/contract/test{index}/joint_commands" for index in range(24)]


class Ros2Rig(DriverRig):
    """The module's subscriber process, read for the JointStates on the test's own topic."""

    profile = PAPER16

    def __init__(self, folder: Path, out: Path, topic: str) -> None:
        super().__init__(folder)
        self.out = out
        self.topic = topic
        self.before = 0

    def received(self) -> list[Received]:
        return [message for message in read_received(self.out) if message.topic == self.topic]

    def config(self) -> dict[str, Any]:
        return {"driver": "ros2", "topic": self.topic, "node": "contract_driver"}

    async def after_connect(self, driver: ServoDriver, count: int) -> None:
        self.before = count - len(self.received())

    def expected(self, positions: Mapping[str, float]) -> Any:
        return {
            name: pytest.approx(self.profile.servo(name).angle.radians(us), abs=1e-9)
            for name, us in positions.items()
        }

    async def observed(self, count: int) -> Any:
        received = self.received()
        if len(received) < count - self.before:
            return f"{len(received)} of {count - self.before} messages"
        last = received[-1]
        return dict(zip(last.names, last.positions, strict=True))

    def bad_configs(self) -> list[tuple[dict[str, Any], str]]:
        return [
            ({"driver": "ros2", "output": "pose"}, "Invalid enum value 'pose'"),
            ({"driver": "ros2", "depth": 0}, "Expected `int` >= 1"),
            ({"driver": "ros2", "topic": "no spaces"}, "--ros2-topic 'no spaces': Invalid topic"),
            ({"driver": "ros2", "node": "a-b"}, "--ros2-node 'a-b': Invalid node name"),
        ]


@pytest.fixture
def ros2_domain(ros2_module_host: int) -> int:
    """The module's domain, its subscriber's (instead of one of each test's own)."""
    return ros2_module_host


@pytest.fixture(scope="module")
def taker(
    ros2_module_host: int, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[tuple[Path, Iterator[str]]]:
    """The module's subscriber to every one of :data:`TOPICS`: its file, and the topics left."""
    out = tmp_path_factory.mktemp("ros2_contract") / "received.jsonl"
    peer = subscriber(dict.fromkeys(TOPICS, "joint_state"), out)
    try:
        yield out, iter(TOPICS)
    finally:
        peer.stop()


@pytest.fixture
async def rig(tmp_path: Path, taker: tuple[Path, Iterator[str]]) -> AsyncIterator[DriverRig]:
    out, topics = taker
    topic = next(topics, None)
    if topic is None:
        pytest.fail(f"more tests than the {len(TOPICS)} topics of TOPICS: add some")
    made = Ros2Rig(tmp_path, out, topic)
    try:
        yield made
    finally:
        await made.aclose()


def test_the_radians_are_the_default_maps() -> None:
    assert PAPER16.servo("jaw").angle.radians(1500) == pytest.approx(math.pi / 2)
