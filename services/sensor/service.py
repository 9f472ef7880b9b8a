"""Sensor S, service shell: a frame source → ``…/input``.

Real-time by default (frames leave at the recording's pace); ``fast`` sends as fast as the chain
takes them, keeping at most ``window`` frames ahead of the last servo command seen, so a replay
loses no frame and gives the same commands every time. Pacing, the credit window's
``ack_timeout`` and the wait for other services run on the context's clock (``ctx.clock``).

Real-time frames name this host's clock as their ``capture_host``
(:func:`~facesynth.runtime.clock_host.clock_host`), or the clock a source says it read
(:meth:`~facesynth.services.sensor.sources.base.FrameSource.capture_clock`: a ROS 2 camera's
stamps), so the stages downstream drop them once they are too old (after a stall); ``fast``
frames wait for credit by design and name none (they are never aged from capture), nor do a
measuring camera's (``capture_age`` off: learn's robot camera, whose frames are measured, never
acted on).

Frames travel as the ``encoding`` option says: ``jpeg`` and ``raw`` to every reader alike;
``auto`` (a graph's default) hands the stages of this process (``facesynth run``) the raw
pixels, and every other reader (a stage or recorder elsewhere, a recorder here) the same frame
as JPEG at ``quality`` (:func:`~facesynth.runtime.frames.jpeg_form`), encoded once, only when
one wants bytes. A camera's own JPEG stays as it is unless ``raw`` is asked for.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator, Callable, Iterator
from dataclasses import dataclass, field

import msgspec

from facesynth.runtime import codec, keys
from facesynth.runtime.clock_host import clock_host
from facesynth.runtime.frames import AUTO, FrameError, jpeg_form, local_encoding, tick_frame
from facesynth.runtime.service import ServiceContext
from facesynth.schemas.messages import Frame
from facesynth.services.sensor.core import Pacer
from facesynth.services.sensor.credit import CreditGate, ack_stage
from facesynth.services.sensor.sources import FrameSource, JpegImage
from facesynth.services.sensor.sources.base import Image


@dataclass
class SensorOptions:
    """How the sensor sends frames."""

    fast: bool = False
    window: int = 2
    ack_timeout: float = 2.0
    #: ``jpeg``, ``raw``, or ``auto`` (raw to this process's stages, JPEG to other readers).
    encoding: str = "jpeg"
    quality: int = 90
    max_frames: int | None = None
    wait_for: list[str] = field(default_factory=list)
    wait_timeout: float = 10.0
    #: Name this host as the frames' capture host (they are then aged downstream).
    capture_age: bool = True


async def wait_for_services(ctx: ServiceContext, services: list[str], timeout: float) -> bool:
    """Wait until every named service of this rig has a liveliness token."""
    if not services:
        return True
    clock = ctx.clock
    deadline = clock.monotonic_ns() + round(timeout * 1e9)
    missing = set(services)
    while True:
        alive = await ctx.bus.alive(keys.health_pattern(ctx.rig), timeout=0.5)
        present = {parsed[1] for key in alive if (parsed := keys.parse_service_key(key))}
        missing = set(services) - present
        if not missing:
            return True
        if clock.monotonic_ns() >= deadline:
            ctx.log.warning(
                "still waiting for %s after %.1f s: starting anyway", sorted(missing), timeout
            )
            return False
        await clock.sleep(0.05)


def jpeg_pixels(image: JpegImage) -> object:
    """The pixels of a camera's JPEG (for ``--encoding raw``); :class:`FrameError` if corrupt."""
    from facesynth.runtime.frames import decode_frame

    return decode_frame(
        Frame(
            seq=0,
            t_capture_ns=0,
            t_media_ns=0,
            width=image.width,
            height=image.height,
            encoding="jpeg",
            data=image.data,
        )
    )


def _next_or_none(frames: Iterator[tuple[Image, int]]) -> tuple[Image, int] | None:
    """The next frame of ``frames``, or None at their end."""
    return next(frames, None)


class SensorService:
    """Publishes the frames of one source; ``last_seq`` is the last frame sent."""

    def __init__(self, source: FrameSource, options: SensorOptions) -> None:
        self.source = source
        self.options = options
        self.last_seq = -1
        self.credit = CreditGate(options.window, options.ack_timeout, "frame")
        #: Whose wall clock stamps the frames (none for ``fast``: see the module doc).
        aged = options.capture_age and not options.fast
        self.capture_host = clock_host() if aged else ""
        #: How a frame becomes bytes for the readers that want bytes.
        self.encode: Callable[[Frame], bytes] = (
            self.jpeg_bytes if options.encoding == AUTO else codec.encode
        )

    def jpeg_bytes(self, frame: Frame) -> bytes:
        """A frame's bytes for readers outside this process and recorders (``auto``): a raw
        frame as JPEG at the options' quality."""
        return codec.encode(jpeg_form(frame, self.options.quality))

    @property
    def stalls(self) -> int:
        """How often ``--fast`` went on without hearing from the end of the chain."""
        return self.credit.stalls

    def _frame(self, image: object, seq: int, t_media_ns: int, now: int) -> Frame:
        from facesynth.runtime.frames import encode_frame  # OpenCV only where pixels exist

        info = self.source.info
        if isinstance(image, JpegImage):
            if self.options.encoding != "raw":  # the camera's own JPEG, as it is
                return Frame(
                    seq=seq,
                    t_capture_ns=now,
                    t_media_ns=t_media_ns,
                    width=image.width,
                    height=image.height,
                    encoding="jpeg",
                    data=image.data,
                    source=info.name,
                    fps=info.fps,
                )
            image = jpeg_pixels(image)
        if image is None:
            return tick_frame(
                seq=seq, t_capture_ns=now, t_media_ns=t_media_ns, source=info.name, fps=info.fps
            )
        return encode_frame(
            image,  # type: ignore[arg-type]
            seq=seq,
            t_capture_ns=now,
            t_media_ns=t_media_ns,
            encoding=local_encoding(self.options.encoding),
            quality=self.options.quality,
            source=info.name,
            fps=info.fps,
        )

    async def _frames(self) -> AsyncIterator[tuple[Image, int]]:
        """The source's frames; taken in a worker thread when the source may wait long."""
        frames = self.source.frames()
        if not self.source.waits:
            for item in frames:
                yield item
            return
        while True:
            taken: tuple[Image, int] | None = await asyncio.to_thread(_next_or_none, frames)
            if taken is None:
                return
            yield taken

    async def serve(self, ctx: ServiceContext) -> int:
        """Send every frame of the source; return the last sequence number sent."""
        options = self.options
        ctx.ready()
        await wait_for_services(ctx, options.wait_for, options.wait_timeout)
        ack_task = None
        if options.fast:
            # Credit comes from the end of the chain: what a control interface applied, or
            # (with no control interface running) what the translator commanded.
            stage = await ack_stage(ctx)
            ctx.log.info("--fast: at most %d frames ahead of %s", options.window, stage)
            ack_task = asyncio.create_task(self.credit.watch(ctx, stage))
        pacer = Pacer()
        info = self.source.info
        ctx.log.info(
            "sensor: %s at %.2f fps (%s) on %s",
            info.name,
            info.fps,
            "fast" if options.fast else "real time",
            ctx.key("input"),
        )
        try:
            previous_media = -1
            seq = -1
            async for image, t_media_ns in self._frames():
                seq += 1
                if options.max_frames is not None and seq >= options.max_frames:
                    break
                if options.fast:
                    await self.credit.wait(ctx, seq)
                elif not info.live:
                    if t_media_ns < previous_media:
                        pacer.restart()
                    delay = pacer.delay_ns(t_media_ns, ctx.clock.monotonic_ns())
                    if delay:
                        await ctx.clock.sleep(delay / 1e9)
                previous_media = t_media_ns
                ctx.stats.received += 1
                try:
                    captured = self.source.capture_time_ns()
                    now = captured if captured is not None else ctx.clock.time_ns()
                    frame = self._frame(image, seq, t_media_ns, now)
                    if self.capture_host:
                        host = self.source.capture_clock() or self.capture_host
                        frame = msgspec.structs.replace(frame, capture_host=host)
                except FrameError as exc:  # e.g. a camera's JPEG that does not decode (raw)
                    ctx.reject(f"frame {seq}: {exc}")
                    continue
                ctx.publish("input", frame, self.encode)
                self.last_seq = seq
                await asyncio.sleep(0)
        finally:
            if ack_task is not None:
                ack_task.cancel()
                with contextlib.suppress(asyncio.CancelledError):
                    await ack_task
            self.source.close()
        return self.last_seq
