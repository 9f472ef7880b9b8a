"""The side-by-side video: performer with landmarks | virtual face | servo bars of a profile.

The renderer runs the chain's pure cores in this process, frame by frame, without the bus
(:class:`facesynth.app.engine.stepped.SteppedChain`): the frame (encoded as the sensor would)
→ the points backend → F → T with the ``virtual`` profile → C's checks and clamping (and the
same for the bars' profile). Every input frame gives exactly one output frame, so the video is
aligned with the input whatever the machine's speed (a real-time bus run drops frames when a
stage falls behind), and a re-render gives the same video. F and T take time from the media
clock, so the controls equal those a ``--fast`` bus run of the same input sends (a test holds
the stepped chain to that). The face is drawn from the same geometry as the live page.

The output is written to a temporary file beside ``out`` and renamed over it when complete.
"""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import cv2
import numpy as np

from facesynth.app.engine.stepped import RobotCores, SteppedChain, sensor_frame
from facesynth.app.render.draw import (
    BarSpec,
    bar_specs,
    draw_bars,
    draw_landmarks,
    draw_shapes,
    draw_title,
    panel,
)
from facesynth.app.render.robot import RobotPanel
from facesynth.runtime.outputs import OutputError, check_output
from facesynth.runtime.profiles import Profile
from facesynth.schemas.messages import Points
from facesynth.services.control.drivers.virtual.geometry import (
    FACE_HEIGHT,
    FACE_WIDTH,
    face_geometry,
)
from facesynth.services.features.core import FeatureError, ibug_points
from facesynth.services.sensor.sources.base import FrameSource, pixels

#: Containers the renderer writes, with their codec.
CODECS = {".mp4": "mp4v", ".mov": "mp4v", ".mkv": "mp4v", ".avi": "MJPG"}


class RenderError(ValueError):
    """A video that cannot be rendered or written; one line."""


def check_render_out(out: str | Path) -> Path:
    """``out`` if the renderer can write a video there (a known container, a writable place),
    else :class:`RenderError`: checked before anything is tracked or run."""
    target = Path(out)
    if CODECS.get(target.suffix.lower()) is None:
        raise RenderError(f"--out {target}: use a {', '.join(CODECS)} file")
    try:
        return check_output(target, "video")
    except OutputError as exc:
        raise RenderError(str(exc)) from None


@dataclass
class Rendered:
    """What one frame gives: the performer's points, the virtual face's controls (``None``
    with a robot), the bars' positions (``None``: no bars), the robot's panel and the second
    robot's (``render --closed-loop``: the same head and profile in open loop)."""

    points: Points
    face: dict[str, float] | None
    bars: dict[str, float] | None
    robot: np.ndarray | None = None
    second: np.ndarray | None = None


#: The stepped chain's robots the renderer shows: the virtual face, and the bars' profile.
FACE = "face"
BARS = "bars"


@dataclass
class RenderChain:
    """The stages a frame goes through: the stepped chain (:class:`SteppedChain`: points
    backend, F, and a T and C per profile shown, :data:`FACE` and :data:`BARS`, C on media time
    as a ``--fast`` run to a virtual face or a file); or, with ``robot``, T and C onto a
    simulated head whose camera image is shown instead of the virtual face (the bars then show
    what C sent the head, unless ``robot_bars`` is off); ``second``, another head shown beside
    it (``render --closed-loop``: the robot in open loop beside the robot in closed loop)."""

    chain: SteppedChain
    encoding: str = "jpeg"
    quality: int = 90
    robot: RobotPanel | None = None
    robot_bars: bool = True
    second: RobotPanel | None = None

    @property
    def face(self) -> RobotCores | None:
        """The virtual face's T and C (``None`` with a robot)."""
        return self.chain.robots.get(FACE)

    @property
    def bars(self) -> RobotCores | None:
        """The bars' T and C (``None``: no bars, or a robot's)."""
        return self.chain.robots.get(BARS)

    @property
    def bars_profile(self) -> Profile | None:
        """The profile the bars show (``None``: no bars)."""
        if self.robot is not None:
            return self.robot.loop.profile if self.robot_bars else None
        return self.bars.profile if self.bars is not None else None

    def step(self, image: np.ndarray, seq: int, t_media_ns: int, fps: float) -> Rendered:
        """Points, the face's controls, the bars' positions and the robot's image for one
        frame."""
        frame = sensor_frame(
            image,
            seq,
            t_media_ns,
            t_capture_ns=time.time_ns(),
            encoding=self.encoding,
            quality=self.quality,
            fps=fps,
        )
        step = self.chain.step(frame, t_media_ns)
        assert step.points is not None and step.features is not None
        if self.robot is not None:
            camera, _ = self.robot.step(step.features)
            bars = self.robot.positions if self.robot_bars else None
            side = image.shape[0] // 2 * 2
            second = None
            if self.second is not None:
                other, _ = self.second.step(step.features)
                second = self.second.picture(other, image.shape[0], side)
            return Rendered(
                step.points, None, bars, self.robot.picture(camera, image.shape[0], side), second
            )
        face = step.positions(FACE) if FACE in step.moves else None
        bars = step.positions(BARS) if BARS in step.moves else None
        return Rendered(step.points, face, bars)


@dataclass
class Layout:
    """Where each panel goes in an output frame."""

    height: int
    width: int
    face_width: int
    bars_width: int
    second_width: int = 0

    @classmethod
    def beside(
        cls, height: int, width: int, bars: bool, robot: bool = False, second: bool = False
    ) -> Layout:
        """The performer at its own size, the face (or the robot's square camera), a second
        robot's camera (``second``) and the bars beside it, as high."""
        face_width = height if robot else round(height * FACE_WIDTH / FACE_HEIGHT) // 2 * 2
        bars_width = round(height * 0.8) // 2 * 2 if bars else 0
        second_width = height // 2 * 2 if second else 0
        return cls(height, width, face_width // 2 * 2, bars_width, second_width)

    @property
    def total_width(self) -> int:
        return self.width + self.face_width + self.second_width + self.bars_width


def compose(
    image: np.ndarray,
    points: Points,
    face: dict[str, float] | np.ndarray,
    bars: tuple[str, list[BarSpec], dict[str, float]] | None,
    layout: Layout,
    second: np.ndarray | None = None,
) -> np.ndarray:
    """One output frame: ``face`` is the virtual face's controls, or the robot's panel;
    ``second``, a second robot's panel after it."""
    performer = image.copy()
    landmarks = None
    if points.face:
        with contextlib.suppress(FeatureError):
            landmarks = ibug_points(points)
    draw_landmarks(performer, landmarks)
    if isinstance(face, np.ndarray):
        face_panel = face
    else:
        face_panel = panel(layout.height, layout.face_width)
        draw_shapes(face_panel, face_geometry(face))
        draw_title(face_panel, "virtual")
    parts = [performer, face_panel] + ([second] if second is not None else [])
    if bars is not None:
        bars_panel = panel(layout.height, layout.bars_width)
        draw_bars(bars_panel, *bars)
        parts.append(bars_panel)
    return np.hstack(parts)


class Progress:
    """A one-line progress bar on a terminal (nothing when ``stream`` is not one)."""

    def __init__(self, total: int | None, stream: IO[str] | None = None, width: int = 30) -> None:
        self.total = total
        self.stream = stream if stream is not None else sys.stderr
        self.width = width
        self.enabled = self.stream.isatty()
        self._started = time.monotonic()
        self._shown = 0.0

    def line(self, done: int, now: float) -> str:
        """The bar for ``done`` frames at monotonic time ``now``."""
        rate = done / max(now - self._started, 1e-9)
        if self.total:
            filled = min(self.width, self.width * done // self.total)
            bar = "#" * filled + "." * (self.width - filled)
            return f"render [{bar}] {done}/{self.total} frames {rate:5.1f} fps"
        return f"render {done} frames {rate:5.1f} fps"

    def update(self, done: int, final: bool = False) -> None:
        """Redraw (at most ten times a second, and at the end)."""
        if not self.enabled:
            return
        now = time.monotonic()
        if final or now - self._shown >= 0.1:
            self._shown = now
            self.stream.write("\r" + self.line(done, now) + ("\n" if final else ""))
            self.stream.flush()


def _frames(source: FrameSource, max_frames: int | None) -> Iterator[tuple[np.ndarray, int]]:
    for index, (image, t_media_ns) in enumerate(source.frames()):
        if max_frames is not None and index >= max_frames:
            return
        if image is None:
            raise RenderError("the renderer needs frames with pixels (a video file)")
        yield pixels(image), t_media_ns


def render_video(
    source: FrameSource,
    chain: RenderChain,
    out: str | Path,
    *,
    max_frames: int | None = None,
    same_size: bool = False,
    progress: Progress | None = None,
) -> dict[str, Any]:
    """Render every frame of ``source`` through ``chain`` into ``out``, atomically.

    ``same_size`` scales each side-by-side frame down into the input's own size (letterboxed);
    otherwise the performer keeps its size and the panels are added beside it.
    """
    target = check_render_out(out)
    codec = CODECS[target.suffix.lower()]
    if source.info.live:
        raise RenderError("the renderer needs a recording (a video file), not a live camera")
    fps = source.info.fps
    total = (
        source.info.frames
        if max_frames is None
        else min(max_frames, source.info.frames or max_frames)
    )
    progress = progress or Progress(total)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(
        prefix=f".{target.stem}.", suffix=target.suffix, dir=target.parent
    )
    os.close(fd)
    tmp = Path(tmp_name)
    writer: cv2.VideoWriter | None = None
    shown = chain.bars_profile
    bars = (shown.name, bar_specs(shown)) if shown is not None else None
    frames = faces = 0
    size = (0, 0)
    started = time.monotonic()
    try:
        for seq, (image, t_media_ns) in enumerate(_frames(source, max_frames)):
            rendered = chain.step(image, seq, t_media_ns, fps)
            if writer is None:
                height, width = image.shape[:2]
                layout = Layout.beside(
                    height,
                    width,
                    bars is not None,
                    chain.robot is not None,
                    chain.second is not None,
                )
                size = (width, height) if same_size else (layout.total_width, height)
                writer = cv2.VideoWriter(str(tmp), cv2.VideoWriter.fourcc(*codec), fps, size)
                if not writer.isOpened():
                    raise RenderError(f"cannot write a {target.suffix} video to {target}")
            if image.shape[:2] != (layout.height, layout.width):
                raise RenderError(
                    f"frame {seq} is {image.shape[1]}x{image.shape[0]}, not "
                    f"{layout.width}x{layout.height} like the first"
                )
            extra = (bars[0], bars[1], rendered.bars or {}) if bars is not None else None
            shown_face = rendered.robot if rendered.robot is not None else rendered.face or {}
            picture = compose(image, rendered.points, shown_face, extra, layout, rendered.second)
            if same_size:
                picture = _letterbox(picture, size)
            writer.write(picture)
            frames += 1
            faces += rendered.points.face
            progress.update(frames)
        if writer is None:
            raise RenderError("the input has no frames")
        writer.release()
        writer = None
        progress.update(frames, final=True)
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(tmp, 0o666 & ~mask)  # as an ordinary new file, not mkstemp's 0600
        os.replace(tmp, target)
    except BaseException:
        if writer is not None:
            writer.release()
        tmp.unlink(missing_ok=True)
        raise
    finally:
        source.close()
    seconds = time.monotonic() - started
    return {
        "video": source.info.name,
        "out": str(target),
        "frames": frames,
        "faces": faces,
        "fps": fps,
        "width": size[0],
        "height": size[1],
        "seconds": round(seconds, 2),
        "render_fps": round(frames / seconds, 1) if seconds > 0 else None,
    }


def _letterbox(picture: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """``picture`` scaled to fit ``size`` (width, height), centred on the background."""
    width, height = size
    scale = min(width / picture.shape[1], height / picture.shape[0])
    scaled = cv2.resize(
        picture,
        (max(1, round(picture.shape[1] * scale)), max(1, round(picture.shape[0] * scale))),
        interpolation=cv2.INTER_AREA,
    )
    canvas = panel(height, width)
    y = (height - scaled.shape[0]) // 2
    x = (width - scaled.shape[1]) // 2
    canvas[y : y + scaled.shape[0], x : x + scaled.shape[1]] = scaled
    return canvas
