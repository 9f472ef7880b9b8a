"""facesynth.app.router_wait: one rule per kind of command for waiting on the router, said in
each command's --help, and ``--router-timeout`` meaning the same wherever it is accepted."""

from __future__ import annotations

import argparse
import functools
from pathlib import Path

import pytest

from facesynth.app import router_wait
from facesynth.app.cli import build_parser
from facesynth.app.router_wait import ONE_SHOT_WAIT_S, RouterWait
from facesynth.app.wiring import zenoh_options

REPO = Path(__file__).resolve().parents[2]


@functools.cache
def _parser() -> argparse.ArgumentParser:
    return build_parser()


def _commands() -> dict[str, argparse.ArgumentParser]:
    parser = _parser()
    (sub,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return dict(sub.choices)


def _flags(parser: argparse.ArgumentParser) -> set[str]:
    return {flag for action in parser._actions for flag in action.option_strings}


def test_every_command_with_a_zenoh_session_has_a_kind() -> None:
    with_zenoh = {name for name, p in _commands().items() if "--connect" in _flags(p)}
    with_zenoh.discard("certs")  # writes configs; opens no session
    assert with_zenoh == set(router_wait.KINDS)


@pytest.mark.parametrize("command", sorted(router_wait.KINDS))
def test_each_commands_help_says_how_it_waits(command: str) -> None:
    parser = _commands()[command]
    kind = router_wait.KINDS[command]
    text = " ".join(parser.format_help().split())
    assert " ".join(router_wait.group_description(kind).split()) in text
    assert ("--router-timeout" in _flags(parser)) == (kind is not RouterWait.OWN_ROUTER)
    if kind is RouterWait.WAITS:
        assert "as long as it takes" in text
    elif kind is RouterWait.ONE_SHOT:
        assert f"default {ONE_SHOT_WAIT_S:g}" in text and "fail at once" in text


def _wait_ms(*argv: str) -> object:
    args = _parser().parse_args(list(argv))
    return zenoh_options(args).overrides.get("connect/timeout_ms")


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["record", "--out", "s.mcap"], -1),  # a recorder waits as long as it takes
        (["inspect"], -1),
        (["status"], round(ONE_SHOT_WAIT_S * 1000)),  # a one-shot tool, then fails
        (["health"], round(ONE_SHOT_WAIT_S * 1000)),
        (["replay", "s.mcap"], round(ONE_SHOT_WAIT_S * 1000)),
        (["status", "--mode", "peer"], round(ONE_SHOT_WAIT_S * 1000)),
        (["record", "--out", "s.mcap", "--mode", "peer"], None),  # a peer needs no router
    ],
)
def test_how_long_each_kind_waits_by_default(argv: list[str], expected: object) -> None:
    assert _wait_ms(*argv) == expected


@pytest.mark.parametrize(
    "argv", [["record", "--out", "s.mcap"], ["inspect"], ["status"], ["health"], ["replay", "x"]]
)
def test_router_timeout_is_the_same_wherever_it_is_accepted(argv: list[str]) -> None:
    assert _wait_ms(*argv, "--router-timeout", "0.5") == 500
    assert _wait_ms(*argv, "--router-timeout", "0") == 0
    config = str(REPO / "deploy" / "zenoh-service.json5")  # its own timeout_ms: -1
    assert _wait_ms(*argv, "--zenoh-config", config, "--router-timeout", "3") == 3000


def test_a_one_shot_tool_never_hangs_on_a_config_files_endless_wait() -> None:
    config = str(REPO / "deploy" / "zenoh-service.json5")
    assert _wait_ms("status", "--zenoh-config", config) == round(ONE_SHOT_WAIT_S * 1000)
    assert _wait_ms("record", "--out", "s.mcap", "--zenoh-config", config) is None  # its own


def test_commands_with_their_own_router_do_not_wait() -> None:
    assert _wait_ms("run") is None
    assert _wait_ms("router") is None
    with pytest.raises(SystemExit):
        _parser().parse_args(["run", "--router-timeout", "1"])
