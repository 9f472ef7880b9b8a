"""facesynth.app.bench.robot_live: a head outside the bench, driven and watched in real time."""

from __future__ import annotations

import asyncio
import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator, Mapping
from pathlib import Path

import numpy as np
import pytest
from simhead16_laugh import laughing, learned_simhead16

from facesynth.app.bench.robot import Performance, RobotError, track_performer
from facesynth.app.bench.robot_live import CameraFeed, live_closed, live_profile
from facesynth.app.cli import main
from facesynth.app.data import sample_video
from facesynth.app.engine.robot_loop import tracker
from facesynth.app.plan.performance import plan_performance
from facesynth.app.simhead import SimHead, load_head
from facesynth.runtime.profiles import Profile, load_profile
from facesynth.schemas.messages import Frame, Points
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.base import ServoDriver
from facesynth.services.points.backends.base import PointsBackend
from facesynth.services.sensor.sources.base import FrameSource, SourceError, SourceInfo

FRAMES = 36


class Rig:
    """A simulated head shared by a driver and a camera, on the monotonic clock."""

    def __init__(self) -> None:
        self.head = SimHead(load_head("simhead16"))
        self.lock = threading.Lock()
        self.origin = time.monotonic_ns()
        self.sent: list[dict[str, float]] = []

    def now(self) -> int:
        return time.monotonic_ns() - self.origin


class HeadDriver(ServoDriver):
    moves_hardware = False

    def __init__(self, rig: Rig, profile: Profile) -> None:
        self.rig = rig
        self.channels = {spec.name: spec.channel for spec in profile.servos}
        self.open = False

    async def connect(self) -> None:
        self.open = True

    async def send(self, positions: Mapping[str, float], info: CommandInfo) -> None:
        assert self.open
        self.rig.sent.append(dict(positions))
        with self.rig.lock:
            self.rig.head.step(self.rig.now())
            for name, pulse in positions.items():
                self.rig.head.command(self.channels[name], pulse)

    async def close(self) -> None:
        self.open = False


class HeadCamera(FrameSource):
    def __init__(self, rig: Rig | None, fps: float = 30.0, frames: int | None = None) -> None:
        self.rig = rig
        self.period = 1.0 / fps
        self.count = frames
        self.info = SourceInfo("head camera", fps, None, live=True)
        self.closed = False

    def frames(self) -> Iterator[tuple[np.ndarray | None, int]]:
        n = 0
        while not self.closed and (self.count is None or n < self.count):
            time.sleep(self.period)
            if self.rig is None:
                yield np.zeros((320, 320, 3), np.uint8), 0
            else:
                with self.rig.lock:
                    self.rig.head.step(self.rig.now())
                    image = self.rig.head.render()
                yield image, self.rig.now()
            n += 1

    def close(self) -> None:
        self.closed = True


@pytest.fixture(scope="module")
def performance() -> Performance:
    return track_performer(str(sample_video()), frames=FRAMES)


@pytest.mark.slow
def test_a_head_is_driven_and_watched_in_real_time(performance: Performance) -> None:
    rig = Rig()
    profile = load_profile("head16")
    camera = CameraFeed(HeadCamera(rig))
    driver = HeadDriver(rig, profile)
    started = time.monotonic()
    try:
        robot = asyncio.run(live_profile(performance, profile, driver, camera, settle_s=0.3))
    finally:
        camera.close()
    took = time.monotonic() - started
    assert took >= FRAMES / performance.fps  # played at the video's rate, not faster
    assert len(robot) == FRAMES and robot.names == performance.stream.names
    assert np.isfinite(robot.column("mouthPucker")).all()
    pucker = robot.column("mouthPucker")
    assert pucker.max() - pucker.min() > 0.05  # the performer's mouth moves: so does the head's
    neutral = profile.neutral_positions()
    assert rig.sent[0] == neutral and rig.sent[-1] == pytest.approx(neutral)  # back at neutral
    assert not driver.open


@pytest.mark.slow
def test_the_loop_closes_through_the_camera_that_measures_the_head() -> None:
    """T corrects its commands from the faces the same camera shows (stamped on T's clock:
    a face on another clock is never paired with the commands that made it, and the loop
    learns nothing), and the head returns to neutral at the end."""
    rig = Rig()
    profile = learned_simhead16()
    laugh = laughing()
    camera = CameraFeed(HeadCamera(rig))
    driver = HeadDriver(rig, profile)
    try:
        robot, state = asyncio.run(
            live_closed(laugh, profile, driver, camera, settle_s=0.3, backend=tracker())
        )
    finally:
        camera.close()
    assert len(robot) == len(laugh.features)
    # the camera runs at the performer's rate: most of her frames bring a new face to T
    assert state.updates >= len(laugh.features) // 2, state.updates
    assert np.abs(state.weights).max() > 0  # and the self-model was corrected from them
    neutral = profile.neutral_positions()
    assert rig.sent[-1] == pytest.approx(neutral) and not driver.open


@pytest.mark.slow
def test_a_plan_is_played_through_c_instead_of_t() -> None:
    """Each performer frame, C gets the plan's command for it (the head in real time, the
    camera watching): the positions sent are the plan's, clamped and speed-limited by C."""
    rig = Rig()
    profile = learned_simhead16()
    laugh = laughing()
    plan = plan_performance(profile, laugh.features).commands()
    camera = CameraFeed(HeadCamera(rig))
    driver = HeadDriver(rig, profile)
    try:
        robot = asyncio.run(
            live_profile(laugh, profile, driver, camera, planned=True, settle_s=0.3)
        )
    finally:
        camera.close()
    assert len(robot) == len(laugh.features)
    planned = [command.positions for command in plan]
    # where C's clamping and speed limits leave it alone, a position sent is the plan's own
    # (83 of 90 here; T's commands for the same frames match 26, its first frames at neutral)
    reached = sum(sent in planned for sent in rig.sent)
    assert reached >= 0.75 * len(planned), (reached, len(planned))
    assert rig.sent[-1] == pytest.approx(profile.neutral_positions()) and not driver.open


def test_a_written_profile_cannot_close_the_loop(performance: Performance) -> None:
    rig = Rig()
    profile = load_profile("head16")
    camera = CameraFeed(HeadCamera(rig))
    try:
        with pytest.raises(RobotError, match="head16 is not learned: no closed loop"):
            asyncio.run(live_closed(performance, profile, HeadDriver(rig, profile), camera))
    finally:
        camera.close()
    assert rig.sent == []  # refused before the head was driven


def test_a_camera_without_a_face_is_an_error(performance: Performance) -> None:
    rig = Rig()
    profile = load_profile("paper16")
    camera = CameraFeed(HeadCamera(None))
    driver = HeadDriver(rig, profile)
    try:
        with pytest.raises(RobotError, match=r"camera showed no face .* paper16's neutral"):
            asyncio.run(
                live_profile(performance, profile, driver, camera, settle_s=0.0, timeout_s=0.5)
            )
    finally:
        camera.close()
    assert rig.sent[-1] == pytest.approx(profile.neutral_positions()) and not driver.open


def test_a_camera_that_stops_is_an_error(performance: Performance) -> None:
    rig = Rig()
    profile = load_profile("paper16")
    camera = CameraFeed(HeadCamera(rig, frames=3))
    try:
        with pytest.raises(SourceError, match="head camera: the camera stopped delivering"):
            asyncio.run(
                live_profile(performance, profile, HeadDriver(rig, profile), camera, settle_s=0.5)
            )
    finally:
        camera.close()


class AnsweringHead(HeadDriver):
    """A head whose device answers every write at once on a pipe the event loop reads, as a
    serial driver reads its board's answers; ``backlog``: the most answers a write found
    unread (a run that keeps the loop from its I/O leaves them all unread, and a Maestro
    driver then reads its board as lost and drops the commands)."""

    async def connect(self) -> None:
        await super().connect()
        self.answers, self.device = os.pipe()
        asyncio.get_running_loop().add_reader(self.answers, self.read)
        self.unread = self.backlog = self.writes = 0

    def read(self) -> None:
        self.unread -= len(os.read(self.answers, 1024))

    async def send(self, positions: Mapping[str, float], info: CommandInfo) -> None:
        await super().send(positions, info)
        self.writes += 1
        self.backlog = max(self.backlog, self.unread)
        self.unread += os.write(self.device, b"a")

    async def close(self) -> None:
        asyncio.get_running_loop().remove_reader(self.answers)
        os.close(self.answers)
        os.close(self.device)
        await super().close()


class SlowTracker(PointsBackend):
    """The tracker on a machine too slow to track a frame in its period."""

    def __init__(self, seconds: float) -> None:
        self.backend = tracker()
        self.seconds = seconds

    def process(self, frame: Frame) -> Points:
        time.sleep(self.seconds)
        return self.backend.process(frame)


def test_a_run_behind_its_frames_still_reads_the_drivers_answers(
    performance: Performance,
) -> None:
    """Each look takes longer than a frame, so every frame is late: the loop still runs the
    driver's I/O between writes (it never did: a loaded machine lost the Maestro)."""
    rig = Rig()
    profile = load_profile("head16")
    camera = CameraFeed(HeadCamera(rig))
    driver = AnsweringHead(rig, profile)
    backend = SlowTracker(1.5 / performance.fps)
    started = time.monotonic()
    try:
        robot = asyncio.run(
            live_profile(
                performance, profile, driver, camera, settle_s=0.0, timeout_s=30, backend=backend
            )
        )
    finally:
        camera.close()
    assert time.monotonic() - started > 1.5 * FRAMES / performance.fps  # late at every frame
    assert len(robot) == FRAMES and driver.writes > FRAMES
    assert driver.backlog <= 1  # at most the last write's answer was still unread


@pytest.mark.slow
def test_the_command_drives_the_simhead_process_through_maestro_and_its_camera_url(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``facesynth simhead`` as a process; ``bench robot --driver maestro --port LINK
    --camera URL`` drives it over its pty and watches its MJPEG camera."""
    link = tmp_path / "simhead-tty"
    process = subprocess.Popen(
        [
            *(sys.executable, "-m", "facesynth", "simhead", "simhead16_stiff"),
            *("--serial-link", str(link), "--http", "127.0.0.1:0"),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert process.stdout is not None
        text = "".join(process.stdout.readline() for _ in range(4))
        url = re.search(r"camera: (http://\S+/camera\.mjpg)", text)
        assert url is not None, text
        out = tmp_path / "live.json"
        argv = [
            *("bench", "robot", "--frames", "48", "--profile", "head16"),
            *("--driver", "maestro", "--port", str(link), "--camera", url.group(1)),
            *("--json", str(out)),
        ]
        assert main(argv) == 0
        assert "head16" in capsys.readouterr().out
        result = json.loads(out.read_text())
        (head,) = result["heads"]
        assert head["head"] == f"maestro {link} | camera {url.group(1)}"
        (run,) = head["profiles"]
        rows = {row["feature"]: row for row in run["features"]}
        # every frame after the performer's neutral (its first second: 24 frames) is compared
        assert rows["brow_lower_left"]["frames"] == 24
        assert run["summary"]["reachable"] > 0
    finally:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(timeout=10)
        finally:
            if process.poll() is None:
                process.kill()
                process.wait()


class StallingCamera(HeadCamera):
    """Shows the head until asked to freeze, then sends nothing new (a stalled stream)."""

    def __init__(self, rig: Rig) -> None:
        super().__init__(rig)
        self.frozen = threading.Event()

    def frames(self) -> Iterator[tuple[np.ndarray | None, int]]:
        for item in super().frames():
            while self.frozen.is_set() and not self.closed:
                time.sleep(0.05)
            yield item


@pytest.mark.slow
def test_a_camera_that_stalls_while_the_head_plays_is_an_error() -> None:
    rig = Rig()
    profile = load_profile("head16")
    source = StallingCamera(rig)
    camera = CameraFeed(source)
    performance = track_performer(str(sample_video()), frames=72)
    clock_origin = time.monotonic_ns()

    def clock() -> int:  # the camera freezes 1.5 s into the run (after the neutral)
        now = time.monotonic_ns()
        if now - clock_origin > 1_500_000_000:
            source.frozen.set()
        return now

    try:
        with pytest.raises(RobotError, match="camera has shown nothing new for 2 s"):
            asyncio.run(
                live_profile(
                    performance,
                    profile,
                    HeadDriver(rig, profile),
                    camera,
                    settle_s=0.2,
                    clock=clock,
                )
            )
    finally:
        source.frozen.clear()
        camera.close()
