"""facesynth.app.profile_choice: the profile a driver expects when none is named, said in one log
line, and a profile whose controls the driver cannot show refused with the ones it can."""

from __future__ import annotations

import logging
from typing import Any

import pytest

from facesynth.app.cli import main
from facesynth.app.graph import GRAPHS_DIR, load_graph, parse_graph
from facesynth.app.nodes import ControlNode, TranslatorNode
from facesynth.app.profile_choice import (
    DEFAULT_PROFILE,
    ProfileFitError,
    check_fit,
    fitting_profiles,
    settle_profiles,
)
from facesynth.runtime.profiles import load_profile
from facesynth.services.control.drivers.virtual import VirtualDriver
from facesynth.services.control.drivers.vmc import VmcConfig, VmcDriver

EXPECTS = "driver expects"


def graph(**controls: dict[str, Any]) -> Any:
    """A graph with one translator and the given control nodes (robot-less)."""
    nodes: dict[str, Any] = {"translator": {"stage": "translator"}}
    nodes.update({name: {"stage": "control", **table} for name, table in controls.items()})
    return parse_graph({"nodes": nodes}, plugins=False)


@pytest.mark.parametrize(
    ("driver", "expected"),
    [({"driver": "vmc"}, "arkit52"), ({"driver": "virtual"}, "virtual")],
)
def test_a_driver_names_its_profile_and_says_so_once(
    driver: dict[str, Any], expected: str, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, logger="facesynth")
    settled = settle_profiles(graph(out={"driver": driver}))
    assert settled.nodes["out"].profile == expected
    assert settled.nodes["translator"].profile == expected  # the translator follows its robot
    lines = [r.getMessage() for r in caplog.records if EXPECTS in r.getMessage()]
    assert lines == [
        f"control node out: no profile given; the {driver['driver']} driver expects {expected}, "
        "using it (choose another with --profile)"
    ]


def test_a_driver_without_a_preference_keeps_the_default_quietly(
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.INFO, logger="facesynth")
    settled = settle_profiles(graph(rec={"driver": {"driver": "record", "out": "x.jsonl"}}))
    assert settled.nodes["rec"].profile == DEFAULT_PROFILE == "paper16"
    assert settled.nodes["translator"].profile == "paper16"
    assert not [r for r in caplog.records if EXPECTS in r.getMessage()]


def test_a_named_profile_is_kept_and_nothing_is_said(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger="facesynth")
    settled = settle_profiles(graph(out={"driver": {"driver": "vmc"}, "profile": "virtual"}))
    assert settled.nodes["out"].profile == "virtual"
    assert settled.nodes["translator"].profile == "virtual"
    assert not [r for r in caplog.records if EXPECTS in r.getMessage()]


def test_the_command_lines_driver_decides_over_the_graphs() -> None:
    settled = settle_profiles(
        graph(out={"driver": {"driver": "record", "out": "x.jsonl"}}), {"out": VmcConfig()}
    )
    assert settled.nodes["out"].profile == "arkit52"


def test_each_robot_follows_its_own_control_node() -> None:
    nodes = {
        "t_face": {"stage": "translator", "robot": "face"},
        "t_head": {"stage": "translator", "robot": "head"},
        "t_lone": {"stage": "translator", "robot": "lone"},
        "c_face": {"stage": "control", "robot": "face", "driver": {"driver": "virtual"}},
        "c_head": {"stage": "control", "robot": "head", "driver": {"driver": "record"}},
    }
    settled = settle_profiles(parse_graph({"nodes": nodes}, plugins=False))
    profiles = {name: node.profile for name, node in settled.nodes.items()}
    assert profiles == {
        "t_face": "virtual",
        "t_head": "paper16",
        "t_lone": "paper16",
        "c_face": "virtual",
        "c_head": "paper16",
    }


def test_a_profile_the_driver_cannot_show_is_refused_with_those_it_can() -> None:
    with pytest.raises(ProfileFitError) as refused:
        settle_profiles(graph(out={"driver": {"driver": "vmc"}, "profile": "head16"}))
    message = str(refused.value)
    assert message.startswith("the vmc driver cannot show ")
    assert "of profile head16 (" in message
    assert message.endswith("choose --profile arkit52 or virtual or virtual_bs")
    assert "\n" not in message


def test_which_profiles_each_driver_shows() -> None:
    assert fitting_profiles(VmcDriver) == ["arkit52", "virtual", "virtual_bs"]
    every = fitting_profiles(VirtualDriver)  # bars for any profile
    assert {"paper16", "head16", "arkit52", "virtual"} <= set(every)
    check_fit(VmcConfig(), load_profile("arkit52"))
    check_fit({"driver": "virtual"}, load_profile("paper16"))
    check_fit({"driver": "no-such-driver"}, load_profile("paper16"))  # said elsewhere
    with pytest.raises(ProfileFitError, match="cannot show 15 of the 16 controls"):
        check_fit({"driver": "vmc"}, load_profile("paper16"))


@pytest.mark.parametrize("file", sorted(GRAPHS_DIR.glob("*.toml")), ids=lambda f: f.stem)
def test_bundled_graphs_settle(file: Any) -> None:
    settled = settle_profiles(load_graph(file))
    for node in settled.nodes.values():
        if isinstance(node, ControlNode | TranslatorNode):
            assert node.profile is not None


def test_the_demo_with_vmc_drives_arkit52(caplog: pytest.LogCaptureFixture) -> None:
    """``facesynth control --driver vmc``: the line is logged before the router is looked for
    (none runs here, so it stops with its own error)."""
    caplog.set_level(logging.INFO, logger="facesynth")
    argv = ["control", "--driver", "vmc", "--router-timeout", "0", "--connect", "tcp/127.0.0.1:9"]
    assert main(argv) == 2
    assert [r.getMessage() for r in caplog.records if EXPECTS in r.getMessage()] == [
        "control node control: no profile given; the vmc driver expects arkit52, using it "
        "(choose another with --profile)"
    ]
