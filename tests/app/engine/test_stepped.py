"""engine.stepped: the chain's cores stepped in process give the commands the services send.

The same graph file is run twice: by ``facesynth run`` (every stage a service on a bus, the
sensor ``--fast``, the commands recorded) and by :class:`SteppedChain` built from it, fed the
frames the sensor plays; every frame's positions must be equal (the record driver keeps three
decimals, so the stepped ones are rounded alike).
"""

from __future__ import annotations

import contextlib
import io
import json
import logging
from pathlib import Path

import msgspec
import pytest
from stepped_chains import graph_chain

from facesynth.app.cli import main
from facesynth.app.data import sample_openface_csv
from facesynth.app.engine.stepped import (
    RobotCores,
    SteppedChain,
    control_core,
    motion_time_of,
    sensor_frame,
)
from facesynth.app.graph import Graph, load_graph, plugin_config
from facesynth.app.nodes import (
    ControlNode,
    PointsNode,
    SensorNode,
    TranslatorNode,
)
from facesynth.app.wiring import OptionError, build_source, replay_frames_of
from facesynth.runtime.profiles import load_profile
from facesynth.schemas.messages import Features, Frame
from facesynth.services.control.drivers.record import RecordConfig, read_record
from facesynth.services.sensor.sources.base import pixels
from facesynth.services.translator.core import Translator

#: The graph both runs read: the bundled OpenFace CSV replayed --fast onto paper16, recorded.
GRAPH = """
rig = "stepped"
[nodes.sensor]
stage = "sensor"
fast = true
[nodes.points]
stage = "points"
backend = {{ backend = "openface", csv = "{csv}" }}
[nodes.features]
stage = "features"
{calibration}
[nodes.translator]
stage = "translator"
profile = "{profile}"
mirror = {mirror}
{calibration}
[nodes.control]
stage = "control"
profile = "{profile}"
mirror = {mirror}
# a loaded machine's stall must not fire the watchdog (its return changes the commands)
watchdog = 5.0
driver = {{ driver = "record", out = "{out}" }}
"""


def _graph(
    tmp_path: Path, profile: str, mirror: bool = False, calibration: Path | None = None
) -> tuple[Path, Path]:
    out = tmp_path / f"{profile}.jsonl"
    path = tmp_path / f"{profile}.toml"
    text = GRAPH.format(
        csv=sample_openface_csv(),
        profile=profile,
        mirror=str(mirror).lower(),
        calibration=f'calibration = "{calibration}"' if calibration else "",
        out=out,
    )
    path.write_text(text)
    return path, out


def _frames(graph: Graph) -> list[Frame]:
    """The frames the graph's sensor plays (ticks: a replay needs no pixels)."""
    sensor = graph.nodes["sensor"]
    source = build_source(plugin_config(sensor, "sensor"), replay_frames_of(graph))  # type: ignore[arg-type]
    try:
        return [sensor_frame(None, seq, t) for seq, (_, t) in enumerate(source.frames())]
    finally:
        source.close()


def _stepped(graph_file: Path) -> tuple[SteppedChain, list[Frame]]:
    graph = load_graph(str(graph_file), plugins=False)
    return graph_chain(graph), _frames(graph)


class _Resumes(logging.Handler):
    """Counts the translator service's resumes (it logs each one)."""

    def __init__(self) -> None:
        super().__init__(logging.INFO)
        self.count = 0

    def emit(self, record: logging.LogRecord) -> None:
        self.count += record.getMessage().startswith("resuming from")


def _run(graph: Path, out: Path) -> dict[int, dict[str, float]]:
    """The commands ``facesynth run GRAPH`` sends, frame by frame (its record file's last
    session). Run again when a stall of the (shared, loaded) machine disturbed the services,
    as they are made to answer one in real time, which a chain in virtual time never meets:
    C refused a command that waited too long (``max_command_age_s``), or, after 0.5 s without
    a command, C reported where it is and T resumed from there."""
    logger = logging.getLogger("facesynth.translator")
    level = logger.level
    for _ in range(4):
        resumes, summary = _Resumes(), io.StringIO()
        logger.addHandler(resumes)
        logger.setLevel(logging.INFO)  # whatever the test session's logging says
        try:
            with contextlib.redirect_stdout(summary):
                assert main(["run", str(graph), "--listen", "tcp/127.0.0.1:0"]) == 0
        finally:
            logger.removeHandler(resumes)
            logger.setLevel(level)
        result = json.loads(summary.getvalue())
        refused = sum(result["rejected"].values()) + sum(result["dropped"].values())
        # one resume: from neutral, before the first command
        if resumes.count <= 1 and not refused and result["commands"] == result["frames"]:
            lines = read_record(out, session=-1)
            return {line.frame: line.servos for line in lines if line.frame is not None}
    raise AssertionError("four runs in a row were disturbed by stalls")


def _differences(
    chain: SteppedChain, frames: list[Frame], sent: dict[int, dict[str, float]]
) -> list[tuple[int, str, float, float]]:
    """The frames whose stepped positions (rounded as recorded) differ from the sent ones:
    per frame, the first servo that differs, stepped and sent."""
    assert len(sent) == len(frames)
    differ = []
    for frame in frames:
        step = chain.step(frame)
        positions = {k: round(v, 3) for k, v in step.positions("translator").items()}
        wanted = sent[frame.seq]
        if positions != wanted:
            name = next(n for n in wanted if positions.get(n) != wanted[n])
            differ.append((frame.seq, name, positions.get(name, float("nan")), wanted[name]))
    return differ


@pytest.fixture(scope="module")
def paper16_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[int, dict]]:
    tmp = tmp_path_factory.mktemp("stepped")
    graph, out = _graph(tmp, "paper16")
    return graph, _run(graph, out)


def test_the_stepped_chain_commands_what_the_services_send(
    paper16_run: tuple[Path, dict[int, dict[str, float]]],
) -> None:
    graph, sent = paper16_run
    chain, frames = _stepped(graph)
    assert len(frames) == 100
    assert _differences(chain, frames, sent) == []
    # the stream moves the face: the comparison is not of neutral poses alone
    neutral = load_profile("paper16").neutral_positions()
    moved = [seq for seq, positions in sent.items() if positions != neutral]
    assert len(moved) > 50


def test_a_translator_built_without_the_profiles_smoothing_is_caught(
    paper16_run: tuple[Path, dict[int, dict[str, float]]],
) -> None:
    """The comparison above fails for a core wired differently from the services."""
    graph, sent = paper16_run
    chain, frames = _stepped(graph)
    robot = chain.robots["translator"]
    assert robot.profile.smoothing is not None
    bare = msgspec.structs.replace(robot.profile, smoothing=None)
    chain.robots["translator"] = RobotCores("translator", Translator(bare), robot.control)
    assert len(_differences(chain, frames, sent)) > 20


@pytest.mark.parametrize(("profile", "mirror"), [("head16", False), ("virtual", True)])
def test_other_profiles_match_too(tmp_path: Path, profile: str, mirror: bool) -> None:
    """A profile driven by named features (gaze, lids, mouth), and the virtual face mirrored."""
    graph, out = _graph(tmp_path, profile, mirror)
    sent = _run(graph, out)
    chain, frames = _stepped(graph)
    assert _differences(chain, frames, sent) == []


#: A short stretch of the bundled video through the tracker (blendshapes on) onto head16_bs.
VIDEO_GRAPH = """
rig = "stepped"
[nodes.sensor]
stage = "sensor"
fast = true
max_frames = {frames}
{encoding}
[nodes.points]
stage = "points"
[nodes.features]
stage = "features"
[nodes.translator]
stage = "translator"
profile = "head16_bs"
[nodes.control]
stage = "control"
profile = "head16_bs"
watchdog = 5.0
driver = {{ driver = "record", out = "{out}" }}
"""


@pytest.mark.parametrize("encoding", ["", 'encoding = "jpeg"'], ids=["auto", "jpeg"])
def test_the_video_through_the_tracker_matches_too(tmp_path: Path, encoding: str) -> None:
    """Frames with pixels, as P in ``run``'s process takes them, through the tracker: raw by
    default (``auto``: the JPEG is only for readers elsewhere), JPEG-encoded with ``jpeg`` (as
    a five-process chain's P takes them)."""
    frames, out, path = 40, tmp_path / "video.jsonl", tmp_path / "video.toml"
    path.write_text(VIDEO_GRAPH.format(frames=frames, out=out, encoding=encoding))
    sent = _run(path, out)
    graph = load_graph(str(path), plugins=False)
    chain = graph_chain(graph)
    sensor = graph.nodes["sensor"]
    assert isinstance(sensor, SensorNode)
    source = build_source(plugin_config(sensor, "sensor"))  # type: ignore[arg-type]
    played = []
    try:
        for seq, (image, t) in enumerate(source.frames()):
            if seq == frames:
                break
            played.append(
                sensor_frame(
                    pixels(image),
                    seq,
                    t,
                    encoding=sensor.encoding,
                    quality=sensor.quality,
                    fps=source.info.fps,
                )
            )
    finally:
        source.close()
    assert _differences(chain, played, sent) == []
    neutral = load_profile("head16_bs").neutral_positions()
    assert sum(positions != neutral for positions in sent.values()) >= 5


def test_a_performers_calibration_is_wired_as_in_the_services(tmp_path: Path) -> None:
    """F's neutral and ranges and T's face ranges from a calibration (made from the stream)."""
    calibration = tmp_path / "performer.json"
    argv = ["calibrate", "performer", "--openface-csv", str(sample_openface_csv())]
    argv += ["--schedule", "neutral=0-1,smile=1.5-3.2", "--out", str(calibration)]
    assert main(argv) == 0
    graph, out = _graph(tmp_path, "paper16", calibration=calibration)
    sent = _run(graph, out)
    chain, frames = _stepped(graph)
    assert _differences(chain, frames, sent) == []
    (tmp_path / "plain").mkdir()
    plain, _ = _graph(tmp_path / "plain", "paper16")
    chain, frames = _stepped(plain)
    assert len(_differences(chain, frames, sent)) > 20  # the calibration changes the commands


def test_each_stage_may_be_left_out_from_the_front() -> None:
    points_only = graph_chain(
        Graph(
            nodes={
                "points": PointsNode(
                    backend={"backend": "openface", "csv": str(sample_openface_csv())}
                )
            }
        )
    )
    step = points_only.step(sensor_frame(None, 0, 0))
    assert step.points is not None and step.points.face and step.features is None
    robot_only = SteppedChain(
        robots=[RobotCores.from_nodes("r", TranslatorNode(profile="paper16"))]
    )
    features = Features(seq=0, t_capture_ns=0, t_media_ns=0, face=False)
    step = robot_only.step(features, t_ns=5)
    assert step.positions("r") == load_profile("paper16").neutral_positions()
    assert [move.kind for move in step.own["r"]] == ["start"]
    with pytest.raises(OptionError, match="no points backend"):
        robot_only.step(sensor_frame(None, 0, 0))


def test_t_and_c_of_different_profiles_are_refused() -> None:
    translator = Translator(load_profile("paper16"))
    with pytest.raises(OptionError, match="translator's profile paper16 is not the control's"):
        RobotCores("r", translator, control_core(ControlNode(profile="head16")))


def test_c_measures_motion_as_its_service_would() -> None:
    record = RecordConfig(out="x.jsonl")
    assert motion_time_of(ControlNode(), record, fast=True) == "media"
    assert motion_time_of(ControlNode(), record, fast=False) == "real"
    assert motion_time_of(ControlNode(motion_time="real"), record, fast=True) == "real"
    assert control_core(ControlNode(watchdog=2.0), record, True).watchdog.timeout_ns == 2 * 10**9


def _moving(seq: int, t_ns: int) -> Features:
    return Features(
        seq=seq, t_capture_ns=0, t_media_ns=t_ns, face=True, neutral_ready=True, deltas=[0.1] * 68
    )


def test_after_a_silence_c_returns_to_neutral_and_t_resumes_from_there() -> None:
    """C's watchdog fires in virtual time between two steps (its return comes with the later
    step), and T, seeing C's report of it, resumes from neutral as its service would."""
    robot = RobotCores.from_nodes("r", TranslatorNode(profile="paper16"))
    chain = SteppedChain(robots=[robot])
    neutral = robot.profile.neutral_positions()
    assert [move.kind for move in chain.step(_moving(0, 0)).own["r"]] == ["start"]
    moved = chain.step(_moving(1, 33_000_000))
    assert moved.own["r"] == [] and moved.positions("r")["right_eyebrow"] > 1590
    assert robot.resuming.resumed is None
    later = chain.step(_moving(2, 2_000_000_000))
    returns = later.own["r"]
    assert {move.kind for move in returns} == {"return"}
    assert returns[0].t_ns > 533_000_000 and returns[-1].positions == neutral
    assert robot.resuming.resumed == "reported"
    assert later.positions("r") == neutral  # resumed at neutral: it ramps up from there
