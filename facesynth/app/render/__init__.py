"""The side-by-side video of a chain's input (``facesynth render``, ``facesynth run --render``).

:func:`render_graph` reads what to run from a graph, as ``facesynth run`` does: the sensor
node's video, the points node's backend, the features node's options, the translator's
calibration and mirroring. The face is the ``virtual`` profile's, with its brows read from the
blendshapes (``virtual_bs``) when the points backend gives them; the bars show another profile
(``bars``, else the graph's translator profile when it is not one of those).

With ``robot_head`` (``facesynth render --robot-head simhead16 [--profile X]``), a simulated
head driven by the translator's profile takes the virtual face's place: performer | the
robot's camera | the bars of what C sent it (:mod:`facesynth.app.render.robot`). With
``closed_loop`` too (``--closed-loop``, a learned profile): performer | the head with T's loop
closed through its camera | the same head and profile in open loop, without bars.
"""

from __future__ import annotations

import contextlib
import logging
from pathlib import Path
from typing import Any

import msgspec

from facesynth.app.engine.stepped import RobotCores, SteppedChain
from facesynth.app.graph import Graph, plugin_config
from facesynth.app.nodes import ControlNode, FeaturesNode, SensorNode, TranslatorNode
from facesynth.app.render.robot import RobotPanel
from facesynth.app.render.video import (
    BARS,
    FACE,
    Progress,
    RenderChain,
    RenderError,
    check_render_out,
    render_video,
)
from facesynth.app.stages.setup import Setup
from facesynth.app.wiring import (
    build_backend,
    build_calibration,
    build_processor,
    build_source,
)
from facesynth.services.sensor.sources.video import VideoConfig

__all__ = ["RenderError", "render_graph", "render_run", "video_input"]

log = logging.getLogger("facesynth.render")

FACE_PROFILE = "virtual"
#: The face when the points backend gives the blendshapes (the ``full`` tracker model, the
#: default): the same face with its brows read from them. The landmark brows read a laugh's
#: squint as a frown (issue 20: 13 % / 31 % of the sample's laughing frames at -0.5 of their
#: travel or lower); the blendshape brows stay in their neutral band there (100 % / 99 %).
FACE_PROFILE_BLENDSHAPES = "virtual_bs"
FACE_PROFILES = (FACE_PROFILE, FACE_PROFILE_BLENDSHAPES)


def _one(graph: Graph, stage: str) -> tuple[str, Any]:
    nodes = graph.of_stage(stage)
    if len(nodes) != 1:
        raise RenderError(f"the renderer needs one {stage} node (the graph has {len(nodes)})")
    return next(iter(nodes.items()))


def video_input(
    graph: Graph, configs: dict[str, msgspec.Struct | None]
) -> tuple[SensorNode, VideoConfig]:
    """The graph's sensor node and the video it plays, or :class:`RenderError` when its input
    cannot be rendered (a camera, images, generated ticks, a looping video): ``run --render``
    checks this before the chain starts, not after it."""
    sensor_name, sensor = _one(graph, "sensor")
    assert isinstance(sensor, SensorNode)
    source_config = configs.get(sensor_name) or plugin_config(sensor, f"node {sensor_name}")
    if not isinstance(source_config, VideoConfig):
        raise RenderError("the renderer needs a video file as input (--video PATH)")
    if source_config.loop:
        raise RenderError("a looping video never ends: render it without --loop")
    return sensor, source_config


def render_run(
    graph: Graph,
    configs: dict[str, msgspec.Struct | None],
    out: str | Path,
    *,
    frames: int,
    interrupted: bool,
    setup: Setup | None = None,
) -> dict[str, Any]:
    """``run --render``: the video of the run's input once the run has ended.

    After Ctrl-C, the video of the ``frames`` frames the sensor played before it: the input is
    a file still on disk and the renderer gives one output frame per input frame, so they are
    the frames the chain was shown. When nothing was played, or Ctrl-C comes again while
    rendering, the render is skipped with one line saying why (no file is left behind), and the
    summary's ``render`` is ``{"skipped": WHY}``.

    ``setup`` is the run's settled setup: the render takes its profiles from it, as the run's
    nodes did, never reading a profile file again.
    """
    if not interrupted:
        return render_graph(graph, configs, out, setup=setup)
    if frames <= 0:
        return _skipped(out, "interrupted before the first frame was played")
    try:  # the notice too: a Ctrl-C that lands while it is written is Ctrl-C again
        log.warning(
            "interrupted after %d frames: rendering them to %s (Ctrl-C again to skip)",
            frames,
            out,
        )
        return render_graph(graph, configs, out, max_frames=frames, setup=setup)
    except KeyboardInterrupt:
        return _skipped(out, "interrupted again while rendering")


def _skipped(out: str | Path, why: str) -> dict[str, Any]:
    log.warning("render skipped: %s (%s not written)", why, out)
    return {"skipped": why}


def render_graph(
    graph: Graph,
    configs: dict[str, msgspec.Struct | None],
    out: str | Path,
    *,
    bars: str | None = None,
    max_frames: int | None = None,
    same_size: bool = False,
    progress: Progress | None = None,
    robot_head: str | None = None,
    setup: Setup | None = None,
    closed_loop: bool = False,
) -> dict[str, Any]:
    """Render the graph's input video side by side with the virtual face (and bars), or with
    the camera of the simulated head ``robot_head``.

    Profiles come from ``setup`` (``run --render``: the run's settled setup, whose files were
    read at its start), else from a setup of this render's own: each file is read once."""
    setup = setup if setup is not None else Setup()
    if closed_loop and robot_head is None:
        raise RenderError("--closed-loop drives a simulated head: give --robot-head HEAD")
    check_render_out(out)
    sensor, source_config = video_input(graph, configs)
    points_name, points = _one(graph, "points")
    backend_config = configs.get(points_name) or plugin_config(points, f"node {points_name}")
    assert backend_config is not None
    _, features = _one(graph, "features")
    assert isinstance(features, FeaturesNode)
    translators = [
        n for n in graph.of_stage("translator").values() if isinstance(n, TranslatorNode)
    ]
    base = translators[0] if translators else TranslatorNode(profile=FACE_PROFILE)
    calibration = build_calibration(base.calibration)
    backend = build_backend(backend_config)
    face_name = FACE_PROFILE_BLENDSHAPES if backend.gives_blendshapes() else FACE_PROFILE
    bars_profile = bars
    if bars_profile is None:
        bars_profile = next(
            (t.profile for t in translators if t.profile not in FACE_PROFILES), None
        )
    # F's neutral window as in a bus run of the graph: the (first) translator profile's.
    neutral_s = setup.loaded(base.profile).neutral_seconds
    if robot_head is not None and bars not in (None, "none"):
        raise RenderError(
            "with --robot-head the bars show what the robot's profile sent it: "
            "--bars takes only none"
        )
    source = build_source(source_config)
    with contextlib.ExitStack() as opened:
        opened.callback(source.close)  # until render_video has it (it closes it then)
        panels: list[RobotPanel] = []
        robots = []
        if robot_head is not None:
            robot_profile = setup.profile(base.profile, base.mirror)
            for closed in (True, False) if closed_loop else (None,):
                panels.append(
                    RobotPanel(
                        robot_head,
                        robot_profile,
                        fps=source.info.fps,
                        calibration=calibration,
                        closed=closed,
                    )
                )
        else:
            shown = [(FACE, face_name)]
            if bars_profile and bars_profile != "none":
                shown.append((BARS, bars_profile))
            for name, profile in shown:  # T and C as a --fast run to a virtual face builds them
                translator = TranslatorNode(
                    profile=profile, mirror=base.mirror, calibration=base.calibration
                )
                control = ControlNode(profile=profile, mirror=base.mirror, motion_time="media")
                robots.append(RobotCores.from_nodes(name, translator, control, setup=setup))
        chain = RenderChain(
            SteppedChain(backend, build_processor(features, neutral_s), robots),
            encoding=sensor.encoding,
            quality=sensor.quality,
            robot=panels[0] if panels else None,
            robot_bars=bars != "none" and not closed_loop,
            second=panels[1] if len(panels) > 1 else None,
        )
        opened.pop_all()
    limit = max_frames if max_frames is not None else sensor.max_frames
    return render_video(
        source,
        chain,
        out,
        max_frames=limit,
        same_size=same_size,
        progress=progress,
    )
