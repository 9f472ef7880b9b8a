"""``--robot-camera CAMERA`` on the translator node: the robot's camera tracked in T's own
process, its faces fed to T's closed loop.

A thread reads the camera (a device index, a /dev/video* path or a stream URL, as ``facesynth
learn --camera`` takes it), runs the tracker (``full`` model, blendshapes on, as while
babbling) and F on each frame, stamped with the wall clock at capture (the clock T's loop
runs on), and keeps the latest few faces for T to read before each command
(:class:`~facesynth.services.translator.robot_face.RobotFaceFeed`). F learns the robot's
neutral from its first second with a face: start it while the head is at neutral (C holds it
there until T's first command, which waits for the performer's own neutral).

This is the application layer (OpenCV, an inference runtime): a board that runs T without a
camera never imports it. ``--robot-rig`` is the alternative that keeps T free of tracking:
the robot's camera as a chain of its own on another rig.
"""

from __future__ import annotations

import collections
import threading
import time
from collections.abc import Callable

from facesynth.schemas.messages import Features
from facesynth.services.sensor.sources.base import FrameSource, pixels

__all__ = ["RobotCamera", "camera_source"]

#: Faces kept between two reads (the oldest dropped beyond).
KEPT = 8
#: F's neutral window on the robot's face (seconds with a face).
NEUTRAL_S = 1.0
#: Seconds between two attempts to open a camera that failed or stopped.
RETRY_S = 1.0


def camera_source(value: str) -> Callable[[], FrameSource]:
    """A function opening the camera ``value`` names (an index, a device path or a stream
    URL), checked now (``ValueError`` in one line when it is not a camera)."""
    from facesynth.services.sensor.sources.registry import SOURCES

    index: int | str = int(value) if value.isdigit() else value
    config = SOURCES.parse({"source": "camera", "index": index}, "--robot-camera")

    def open_camera() -> FrameSource:
        source: FrameSource = SOURCES.build(config)
        return source

    return open_camera


class RobotCamera:
    """The robot's faces from its camera, tracked on a thread of its own."""

    def __init__(
        self,
        open_source: Callable[[], FrameSource],
        clock: Callable[[], int] = time.time_ns,
        model: str = "full",
    ) -> None:
        """``open_source`` opens the camera (on the thread: a camera that cannot open is an
        :attr:`error`, and the loop stays open)."""
        from facesynth.services.features.core import FeatureProcessor
        from facesynth.services.points.backends.tracker import TrackerBackend, TrackerConfig

        self.open_source, self.clock = open_source, clock
        self.source: FrameSource | None = None
        self.backend = TrackerBackend(TrackerConfig(model=model))
        self.processor = FeatureProcessor(neutral_seconds=NEUTRAL_S)
        self._faces: collections.deque[Features] = collections.deque(maxlen=KEPT)
        self._lock = threading.Lock()
        self._stop = threading.Event()
        #: Why the camera stopped (None: it did not).
        self.error: str | None = None
        self._thread = threading.Thread(target=self._read, name="robot-camera", daemon=True)
        self._thread.start()

    def _read(self) -> None:
        """Open the camera and track its frames; a camera that cannot open, fails or stops is
        an :attr:`error` until it delivers again, tried every :data:`RETRY_S`."""
        from facesynth.runtime.frames import encode_frame

        seq = 0
        while not self._stop.is_set():
            try:
                self.source = self.open_source()
                for image, _ in self.source.frames():
                    if self._stop.is_set():
                        return
                    if image is None:
                        continue
                    now = self.clock()
                    frame = encode_frame(
                        pixels(image), seq=seq, t_capture_ns=now, t_media_ns=now, encoding="raw"
                    )
                    seq += 1
                    features = self.processor.process(self.backend.process(frame))
                    with self._lock:
                        self._faces.append(features)
                    self.error = None
                self.error = "the robot's camera stopped delivering frames"
            except Exception as exc:  # the loop goes on open: said by whoever reads it
                self.error = f"the robot's camera failed: {exc}"
            if self.source is not None:
                self.source.close()
                self.source = None
            self._stop.wait(RETRY_S)

    def faces(self) -> list[Features]:
        """The faces tracked since the last call, oldest first."""
        with self._lock:
            out = list(self._faces)
            self._faces.clear()
        return out

    def close(self) -> None:
        """Stop reading and release the camera."""
        self._stop.set()
        self._thread.join(timeout=RETRY_S + 2.0)
        if self.source is not None and not self._thread.is_alive():
            self.source.close()
