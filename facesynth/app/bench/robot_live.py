"""``facesynth bench robot --driver … --camera …``: a head measured in real time.

The same measurement as the in-process bench (:mod:`.robot`), on a head that lives outside
this process (a real one, or ``facesynth simhead``): each profile drives it through a servo
driver of the control service (``--driver maestro --port …``, ``arduino``, ``ssc32``), and a
camera source (``--camera``: a device index, a ``/dev/video*`` path or a stream URL) watches
it. The performer's features are the cached ones (tracked in process from the video); they
are played at the video's rate on the monotonic clock:

* C (:class:`facesynth.services.control.core.ControlCore`, real time) starts the head at neutral and
  makes its own catch-up steps between commands, as the control service does, each sent
  through the driver; T and C are the stepped chain's
  (:class:`facesynth.app.engine.stepped.RobotCores`), stepped on the monotonic clock;
* the head is held at neutral for :data:`.robot.SETTLE_S`, then F learns the robot's neutral
  from the camera;
* at each performer frame's instant: T → C → the driver, then the camera's latest frame →
  the tracker → F gives the robot's frame (a frame late at least: the camera shows what the
  head did before this command; :func:`.robot_compare.best_lag` measures how late);
* at the end (or on an error, a camera that shows nothing new for 2 s among them) C returns
  the head to neutral within its limits before the driver closes.

With the loop closed (:func:`live_closed`, ``--closed-loop``) each face the camera shows is
also handed to T, which corrects the next frames' commands from it
(:mod:`facesynth.services.translator.closed_loop`), as ``run --robot-camera`` does: one camera
both closes the loop and measures the likeness. With a plan (:func:`live_profile`'s
``planned``, ``--planned``) C gets the plan's command for each frame instead of T's.

A machine too slow to track each frame in its period plays the frames late rather than
skipping them; the run time says so.
"""

from __future__ import annotations

import asyncio
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import msgspec
import numpy as np

from facesynth.app.engine.robot_loop import (
    NEUTRAL_S,
    NEUTRAL_TIMEOUT_S,
    SETTLE_S,
    RobotError,
    robot_features,
    tracker,
)
from facesynth.app.engine.stepped import RobotCores, sensor_frame
from facesynth.app.plan.performance import plan_performance
from facesynth.runtime.calibration import Calibration
from facesynth.runtime.profiles import Profile
from facesynth.schemas.messages import Features, ServoCommands
from facesynth.services.control.core import MAX_STEP_S, Move
from facesynth.services.control.drivers.base import ServoDriver
from facesynth.services.control.freshness import Arrival
from facesynth.services.features.core import FeatureProcessor
from facesynth.services.points.backends.base import PointsBackend
from facesynth.services.sensor.sources.base import FrameSource, SourceError, pixels
from facesynth.services.translator.closed_loop import ClosedLoop, LoopOptions, LoopState

from .robot import Performance
from .robot_compare import FeatureStream

__all__ = ["CameraFeed", "CameraFrame", "live_closed", "live_profile"]

MAX_STEP_NS = round(MAX_STEP_S * 1e9)
#: A camera that shows nothing new for this long while the head plays is an error.
CAMERA_STALL_NS = 2_000_000_000


@dataclass(frozen=True)
class CameraFrame:
    """The camera's latest image, its number (from 1) and when it arrived (monotonic ns)."""

    image: np.ndarray
    number: int
    t_ns: int


class CameraFeed:
    """A live source read on a thread of its own, keeping only its latest frame."""

    def __init__(self, source: FrameSource, clock: Callable[[], int] = time.monotonic_ns):
        self.source = source
        self._clock = clock
        self._lock = threading.Lock()
        self._latest: CameraFrame | None = None
        self._error: BaseException | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._read, name="bench-robot-camera", daemon=True)
        self._thread.start()

    def _read(self) -> None:
        number = 0
        try:
            for image, _ in self.source.frames():
                if self._stop.is_set():
                    return
                if image is None:
                    continue
                number += 1
                with self._lock:
                    self._latest = CameraFrame(pixels(image), number, self._clock())
            raise SourceError(f"{self.source.info.name}: the camera stopped delivering frames")
        except BaseException as exc:  # handed to the reader of the frames
            with self._lock:
                self._error = exc

    def latest(self) -> CameraFrame | None:
        """The latest frame (``None`` before the first); the camera's error if it failed."""
        with self._lock:
            if self._error is not None and not self._stop.is_set():
                raise self._error
            return self._latest

    def close(self) -> None:
        """Stop reading and release the source."""
        self._stop.set()
        self._thread.join(timeout=2.0)
        self.source.close()


class _Live:
    """One profile's real-time run: C's moves to the driver, the camera to F."""

    def __init__(
        self,
        profile: Profile,
        driver: ServoDriver,
        camera: CameraFeed,
        backend: PointsBackend,
        clock: Callable[[], int],
        calibration: Calibration | None = None,
        loop: LoopOptions | None = None,
        planned: list[ServoCommands] | None = None,
    ) -> None:
        self.profile = profile
        self.driver = driver
        self.camera = camera
        self.backend = backend
        self.clock = clock
        #: T and C as the stepped chain runs them, here on the monotonic clock (T with the
        #: performer's calibration, if any, as ``run`` gives it).
        self.cores = RobotCores.of_profile("robot", profile, calibration=calibration)
        self.control = self.cores.control
        #: T's clock (the wall clock, as ``run`` gives it) less this run's: camera frames
        #: arrive on this run's clock and T's closed loop reads them on its own.
        self.wall_offset_ns = time.time_ns() - clock()
        #: A plan's commands, one per performer frame, played through C instead of T's.
        self.planned = planned
        #: T's loop closed through this camera (None: open loop).
        self.closed: ClosedLoop | None = None
        if loop is not None:
            try:
                self.closed = self.cores.translator.close_loop(loop)
            except ValueError as exc:
                raise RobotError(str(exc)) from None
        self.processor = FeatureProcessor(neutral_seconds=NEUTRAL_S, neutral_held=True)
        self.seq = 0
        self.seen = 0

    async def send(self, move: Move | None) -> None:
        if move is not None and move.send:
            await self.driver.send(move.positions, move.info)

    async def until(self, t_ns: int) -> None:
        """C's own moves (catch-up, return) until ``t_ns``, sent as they fall due."""
        while True:
            due = min(self.control.due_ns(), t_ns)
            wait = due - self.clock()
            # Late (tracking took longer than a frame) still yields: the driver's writes and
            # answers are the event loop's I/O, and a loop that never ran read a live Maestro
            # as lost (no answer to Get Errors for 2 s) and dropped the run's commands.
            await asyncio.sleep(max(wait, 0) / 1e9)
            if due >= t_ns:
                return
            move = self.cores.tick(self.clock())
            if move is None:  # nothing was due after all: wait a step rather than spin
                await asyncio.sleep(min(t_ns - self.clock(), MAX_STEP_NS) / 1e9)
            await self.send(move)

    def look(self, learn: bool = True) -> Features | None:
        """The camera's latest frame through the tracker (and F); ``None`` when it has not
        delivered a new frame since the last look."""
        frame = self.camera.latest()
        if frame is None or frame.number == self.seen:
            return None
        self.seen = frame.number
        encoded = sensor_frame(frame.image, self.seq, frame.t_ns, t_capture_ns=frame.t_ns)
        self.seq += 1
        points = self.backend.process(encoded)
        return self.processor.process(points) if learn else None

    async def neutral(self, period_ns: int, settle_ns: int, timeout_ns: int) -> Mapping[str, float]:
        """Hold the head at neutral until F knows the robot's neutral; its raw features then."""
        start = self.clock()
        await self.send(self.cores.start(start))
        limit = start + settle_ns + timeout_ns
        while self.clock() <= limit:
            await self.until(self.clock() + period_ns)
            settled = self.clock() - start >= settle_ns
            features = self.look(learn=settled)
            raw = robot_features(features) if features is not None else None
            if raw is not None:
                return raw
        raise RobotError(
            f"the camera showed no face (or no neutral) with the head held at "
            f"{self.profile.name}'s neutral within {(limit - start) / 1e9:.0f} s"
        )

    async def play(
        self, performance: Performance, last: Mapping[str, float] | None
    ) -> list[Mapping[str, float] | None]:
        """Every performer frame at its instant; the robot's raw features per frame (while the
        camera shows nothing new, the last ones: at first ``last``, the neutral's)."""
        start = fresh = self.clock()
        out: list[Mapping[str, float] | None] = []
        for index, performer in enumerate(performance.features):
            await self.until(start + performer.t_media_ns)
            now = self.clock()
            await self.send(self._command(index, performer, now))
            features = self.look()
            if features is not None:
                last, fresh = robot_features(features), now
                if self.closed is not None:  # T corrects the next frames from this face
                    seen = features.t_capture_ns + self.wall_offset_ns
                    self.cores.translator.observe(
                        msgspec.structs.replace(features, t_capture_ns=seen)
                    )
            elif now - fresh > CAMERA_STALL_NS:  # else nothing new yet: as before
                raise RobotError(
                    f"the camera has shown nothing new for {CAMERA_STALL_NS / 1e9:.0f} s"
                )
            out.append(last)
        return out

    def _command(self, index: int, performer: Features, now: int) -> Move | None:
        """C's move for performer frame ``index``: T's command for it, or the plan's (none
        past the plan's last: C's own moves go on, then its return to neutral)."""
        wall = now + self.wall_offset_ns
        if self.planned is None:
            return self.cores.command(performer, now, wall_ns=wall)[1]
        if index >= len(self.planned):
            return None
        return self.control.command(self.planned[index], Arrival(wall, now))[0]

    async def stop(self) -> None:
        """C's return to neutral, sent, before the driver closes."""
        self.control.stop(self.clock())
        limit = self.clock() + round(self.control.stop_budget_s() * 1e9)
        while not self.control.stopped and self.clock() <= limit:
            await self.until(self.control.due_ns())
            await self.send(self.cores.tick(self.clock()))


async def live_profile(
    performance: Performance,
    profile: Profile,
    driver: ServoDriver,
    camera: CameraFeed,
    *,
    planned: bool = False,
    settle_s: float = SETTLE_S,
    timeout_s: float = NEUTRAL_TIMEOUT_S,
    backend: PointsBackend | None = None,
    clock: Callable[[], int] = time.monotonic_ns,
) -> FeatureStream:
    """One profile driving a head through ``driver``, watched through ``camera``, in real
    time (see the module doc): the robot's raw features per performer frame (a
    :class:`.robot.RobotError` when no face with a neutral is seen within ``timeout_s`` after
    ``settle_s`` at neutral).

    ``planned``: ``profile``'s plan of the whole performance (``facesynth plan``, no lead, not
    rehearsed) is played through C instead of T's commands (``bench robot --planned --driver
    …``), as ``facesynth replay PLAN --from servo_commands`` gives it to the control service
    (a :class:`~facesynth.app.plan.performance.PlanError` for a profile without a
    ``poly_ridge`` self-model)."""
    commands = plan_performance(profile, performance.features).commands() if planned else None
    run = _Live(
        profile,
        driver,
        camera,
        _backend(backend),
        clock,
        performance.calibration,
        planned=commands,
    )
    return await _played(run, performance, settle_s, timeout_s)


async def live_closed(
    performance: Performance,
    profile: Profile,
    driver: ServoDriver,
    camera: CameraFeed,
    *,
    loop: LoopOptions | None = None,
    settle_s: float = SETTLE_S,
    timeout_s: float = NEUTRAL_TIMEOUT_S,
    backend: PointsBackend | None = None,
    clock: Callable[[], int] = time.monotonic_ns,
) -> tuple[FeatureStream, LoopState]:
    """:func:`live_profile` with T's loop closed through the same camera (``bench robot
    --closed-loop --driver …``): each face the camera shows is handed to T (stamped on T's
    clock), which corrects the next frames' commands from it, as ``run --robot-camera`` does.
    The robot's raw features and what the loop learned; a :class:`.robot.RobotError` for a
    profile whose loop cannot close (not learned, no ``poly_ridge`` self-model)."""
    options = loop if loop is not None else LoopOptions()
    run = _Live(profile, driver, camera, _backend(backend), clock, performance.calibration, options)
    stream = await _played(run, performance, settle_s, timeout_s)
    assert run.closed is not None
    return stream, run.closed.state


def _backend(backend: PointsBackend | None) -> PointsBackend:
    return backend if backend is not None else tracker()


async def _played(
    run: _Live, performance: Performance, settle_s: float, timeout_s: float
) -> FeatureStream:
    period_ns = round(1e9 / performance.fps)
    async with run.driver:
        try:
            at_neutral = await run.neutral(period_ns, round(settle_s * 1e9), round(timeout_s * 1e9))
            frames = await run.play(performance, at_neutral)
        finally:
            await run.stop()
    return FeatureStream.from_frames(frames, names=performance.stream.names)
