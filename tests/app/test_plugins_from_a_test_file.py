"""A driver and a points backend defined in this file alone are usable from the CLI and a graph.

Nothing else in the project names them: registering is all it takes.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Annotated

import msgspec
import pytest

from facesynth.app.cli import main
from facesynth.app.data import sample_openface_csv
from facesynth.runtime.landmarks import IBUG68
from facesynth.runtime.profiles import Profile
from facesynth.schemas.messages import Frame, Points
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.base import ServoDriver
from facesynth.services.control.drivers.registry import DRIVERS
from facesynth.services.points.backends.base import PointsBackend, face_points, point_set
from facesynth.services.points.backends.registry import BACKENDS
from facesynth.services.points.openface_csv import load_openface_csv

SENT: list[tuple[str, int | None, dict[str, float]]] = []


class MemoConfig(
    msgspec.Struct, tag="memo", tag_field="driver", kw_only=True, forbid_unknown_fields=True
):
    """Keep every command in memory."""

    label: Annotated[str, msgspec.Meta(description="a label for the commands")] = "graph"


class MemoDriver(ServoDriver):
    """Keeps every command in memory (a driver known only to this test file)."""

    moves_hardware = False  # so a --fast chain limits its speeds on media time

    def __init__(self, config: MemoConfig, profile: Profile) -> None:
        self.label = config.label
        self.profile = profile

    async def connect(self) -> None:
        SENT.clear()

    async def send(self, positions: Mapping[str, float], info: CommandInfo) -> None:
        SENT.append((self.label, info.frame, dict(positions)))

    async def close(self) -> None:
        pass


class JawConfig(
    msgspec.Struct, tag="jaw", tag_field="backend", kw_only=True, forbid_unknown_fields=True
):
    """A face that opens its jaw."""

    drop: Annotated[float, msgspec.Meta(description="jaw drop in pixels per frame")] = 1.0


class JawBackend(PointsBackend):
    """The first OpenFace face, its chin and lower lip dropping a little more every frame."""

    name = "jaw"

    def __init__(self, config: JawConfig) -> None:
        self.points = load_openface_csv(sample_openface_csv())[0].points
        self.drop = config.drop

    def process(self, frame: Frame) -> Points:
        points = self.points.copy()
        points[5:12, 1] += self.drop * frame.seq  # chin
        points[55:60, 1] += self.drop * frame.seq  # lower lip
        return face_points(frame, [point_set(IBUG68, points)], 1.0, self.name)


@pytest.fixture
def registered() -> Iterator[None]:
    DRIVERS.register(MemoConfig)(MemoDriver)
    BACKENDS.register(JawConfig)(JawBackend)
    yield
    DRIVERS.unregister("memo")
    BACKENDS.unregister("jaw")


GRAPH = """\
rig = "{rig}"
[nodes.sensor]
stage = "sensor"
source = {{ source = "ticks", count = 40, fps = 200 }}
fast = true
[nodes.points]
stage = "points"
backend = {{ backend = "jaw", drop = 0.5 }}
[nodes.features]
stage = "features"
neutral_seconds = 0.02
[nodes.translator]
stage = "translator"
profile = "paper16"
[nodes.control]
stage = "control"
profile = "paper16"
driver = {{ driver = "memo" }}
"""


def test_the_cli_lists_and_offers_them(
    registered: None, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["control", "--list-drivers"]) == 0
    listing = capsys.readouterr().out
    assert "memo: Keeps every command in memory" in listing
    assert "--label" in listing and "a label for the commands" in listing
    with pytest.raises(SystemExit):
        main(["points", "--help"])
    assert "jaw: The first OpenFace face" in " ".join(capsys.readouterr().out.split())


def test_a_graph_runs_them_and_flags_override_the_graph(
    registered: None, tmp_path: Path, rig: str, capsys: pytest.CaptureFixture[str]
) -> None:
    graph = tmp_path / "graph.toml"
    graph.write_text(GRAPH.format(rig=rig))
    argv = ["run", str(graph), "--label", "cli", "--listen", "tcp/127.0.0.1:0"]
    assert main(argv) == 0
    frames = [frame for label, frame, _ in SENT if frame is not None]
    assert {label for label, _, _ in SENT} == {"cli"}
    assert frames == list(range(40))
    jaw = [positions["jaw"] for _, frame, positions in SENT if frame is not None]
    assert jaw[-1] > jaw[0] + 50, "the jaw opens with the test backend's face"
    assert '"commands": 40' in capsys.readouterr().out


def test_a_flag_of_another_driver_is_refused(
    registered: None, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["control", "--driver", "record", "--label", "x", "--out", "o.jsonl"]) == 2
    assert "--label does not apply to driver record (its options: --out)" in capsys.readouterr().err
