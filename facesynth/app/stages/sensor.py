"""S, the sensor: frames from a source (video, camera, images, ticks…) on ``…/input``."""

from __future__ import annotations

from typing import Annotated, Any, Literal

import msgspec
from msgspec import Meta

from facesynth.app.data import sample_video
from facesynth.app.stages.descriptor import NodeBuild, PluginTable, StageDescriptor, StageParts
from facesynth.app.stages.node import StageNode
from facesynth.runtime.frames import AUTO
from facesynth.services.sensor.service import SensorOptions, SensorService
from facesynth.services.sensor.sources.base import FrameSource, SourceError
from facesynth.services.sensor.sources.registry import SOURCES
from facesynth.services.sensor.sources.ticks import TicksConfig
from facesynth.services.sensor.sources.video import VideoConfig


class SensorNode(StageNode, tag="sensor"):
    """S: frames from a source on ``…/input``."""

    source: dict[str, Any] = msgspec.field(default_factory=lambda: {"source": "video"})
    fast: Annotated[
        bool, Meta(description="as fast as the chain takes frames, none lost (default: real time)")
    ] = False
    window: Annotated[
        int, Meta(ge=1, description="--fast: frames in flight ahead of the last servo command")
    ] = 2
    encoding: Annotated[
        Literal["auto", "jpeg", "raw"],
        Meta(
            description="frame encoding: jpeg, raw, or auto (the default): raw pixels to the "
            "stages in the sensor's own process (facesynth run), JPEG at --quality to every "
            "other process and to recordings; jpeg gives a one-process run the very frames of "
            "a five-process chain"
        ),
    ] = "auto"
    quality: Annotated[int, Meta(ge=1, le=100, description="JPEG quality 1-100 (default 90)")] = 90
    max_frames: Annotated[int, Meta(ge=0, description="stop after N frames")] | None = None
    wait_for: Annotated[
        list[str],
        Meta(
            description="wait until these services are alive before sending, e.g. "
            "points,features,translator,control (default: the graph's other stages)"
        ),
    ] = msgspec.field(default_factory=list)
    wait_timeout: Annotated[
        float, Meta(ge=0, description="seconds to wait for --wait-for (default 30)")
    ] = 30.0
    capture_age: Annotated[
        bool,
        Meta(
            description="name this host as the frames' capture host, so the stages downstream "
            "drop frames too old to act on after a stall (default on; off for a camera that "
            "only measures, as learn's robot camera; --fast frames are never aged)"
        ),
    ] = True


def build_source(config: msgspec.Struct, replay_frames: int | None = None) -> FrameSource:
    """The frame source of a config; the bundled video when a video source names no file.

    With a replayed point stream (``replay_frames``) and no video named, ticks drive the chain.
    """
    if isinstance(config, VideoConfig) and config.path is None:
        if replay_frames is not None:
            return SOURCES.build(TicksConfig(count=replay_frames, fps=config.fps))
        path = sample_video()
        if not path.is_file():
            raise SourceError(f"the bundled sample video is missing ({path}); pass --video")
        config = msgspec.structs.replace(config, path=str(path))
    return SOURCES.build(config)


def sensor_options(node: SensorNode, standalone: bool = False) -> SensorOptions:
    """The sensor's pacing and encoding options; ``auto`` is JPEG for a sensor in a process of
    its own (``standalone``: no stage of its process takes its frames)."""
    return SensorOptions(
        fast=node.fast,
        window=node.window,
        encoding="jpeg" if standalone and node.encoding == AUTO else node.encoding,
        quality=node.quality,
        max_frames=node.max_frames,
        wait_for=list(node.wait_for),
        wait_timeout=node.wait_timeout,
        capture_age=node.capture_age,
    )


def build(request: NodeBuild) -> StageParts:
    """A sensor node: its source, paced as the node says."""
    assert request.config is not None
    sensor = SensorService(
        build_source(request.config, request.replay_frames),
        sensor_options(request.node, request.standalone),
    )
    return StageParts(request.name, STAGE.name, sensor.serve, sensor)


STAGE = StageDescriptor(
    name="sensor",
    node=SensorNode,
    build=build,
    consumes=None,
    produces="input",
    help="S: publish frames from a video, camera or image folder on …/input",
    plugin=PluginTable("source", SOURCES, "--source", default="video"),
)
