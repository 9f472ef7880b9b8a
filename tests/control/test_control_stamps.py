"""The wall-clock instant C stamps on each move it hands a driver (what the ``record`` driver
writes as ``t_sent_ns``, and what the soak's motion check measures steps against)."""

from __future__ import annotations

from collections.abc import Mapping

from facesynth.runtime.clock import FAKE_EPOCH_NS, FakeClock
from facesynth.runtime.profiles import load_profile
from facesynth.runtime.testing import StageRun
from facesynth.schemas.messages import ServoCommands
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.base import ServoDriver
from facesynth.services.control.service import ControlService

MS = 1_000_000


class PausingClock(FakeClock):
    """A fake clock whose thread is preempted for ``pause_ns`` right after its ``pause_after``-th
    wall reading from now: the next monotonic reading comes that much later."""

    pause_ns = 2 * MS

    def __init__(self) -> None:
        super().__init__()
        self.pause_after = 0  # 0: never
        self._pending = False

    def time_ns(self) -> int:
        wall = super().time_ns()
        if self.pause_after > 0:
            self.pause_after -= 1
            self._pending = self.pause_after == 0
        return wall

    def monotonic_ns(self) -> int:
        if self._pending:
            self._pending = False
            self._now += self.pause_ns
        return super().monotonic_ns()


class StampDriver(ServoDriver):
    """Keeps the stamp of every send."""

    moves_hardware = False

    def __init__(self) -> None:
        self.stamps: list[int | None] = []

    async def connect(self) -> None:
        pass

    async def send(self, positions: Mapping[str, float], info: CommandInfo) -> None:
        self.stamps.append(info.t_ns)

    async def neutral(self, positions: Mapping[str, float]) -> None:
        pass

    async def close(self) -> None:
        pass


async def test_a_pause_while_reading_the_clocks_does_not_shift_the_step_s_stamp() -> None:
    clock = PausingClock()
    driver = StampDriver()
    control = ControlService(load_profile("paper16"), driver, watchdog_s=5.0)
    async with StageRun(control.serve, service="control", clock=clock) as run:
        await run.advance(0.2)
        # The test's own wall readings (StageRun's, the bus stamping the sample), then C's at
        # the command's arrival: C is preempted 2 ms after that one, before its next monotonic
        # reading, the one it stamps the step with.
        clock.pause_after = 3
        command = ServoCommands(
            seq=1, t_capture_ns=0, t_media_ns=0, face=True, profile="paper16",
            positions={"jaw": 1600.0},
        )  # fmt: skip
        await run.send("servo_commands", command)
        assert clock.pause_after == 0 and not clock._pending, "the pause fell on a reading"
        # The command arrived at 200 ms: its step is stamped at that wall instant, exactly
        # (a stamp read as time_ns() - monotonic_ns() around the pause was 2 ms early).
        assert driver.stamps[-1] == FAKE_EPOCH_NS + 200 * MS
