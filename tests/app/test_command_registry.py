"""The command registry: every ``facesynth`` sub-command is declared by one registered module,
the parser holds exactly the registered commands, and a name given twice is refused."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import pytest

from facesynth.app.cli import build_parser
from facesynth.app.command_registry import COMMAND_MODULES, Command, add_commands, commands

ROOT = Path(__file__).resolve().parents[2]


def parser_commands(parser: argparse.ArgumentParser) -> list[str]:
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return list(action.choices)


def test_the_parser_holds_exactly_the_registered_commands_in_their_order() -> None:
    registered = [command.name for command in commands()]
    assert parser_commands(build_parser()) == registered
    assert registered[:6] == ["run", "sensor", "points", "features", "translator", "control"]
    assert {"record", "replay", "learn", "doctor", "console", "simhead"} <= set(registered)


def test_every_module_that_declares_commands_is_registered() -> None:
    declaring = set()
    for path in (ROOT / "facesynth").rglob("*.py"):
        if re.search(r"^COMMANDS = ", path.read_text(), re.M):
            module = ".".join(path.relative_to(ROOT).with_suffix("").parts)
            declaring.add(module)
    assert declaring == set(COMMAND_MODULES)


def test_a_command_registered_twice_is_refused() -> None:
    with pytest.raises(ValueError, match=r"'status' is registered by .*status and by .*status"):
        list(commands(("facesynth.app.commands.status", "facesynth.app.commands.status")))


def test_a_command_declares_its_arguments_defaults_and_handler_on_its_parser() -> None:
    def greet(args: argparse.Namespace) -> int:
        return 7 if args.loud and args.kind == "test" else 0

    def arguments(p: argparse.ArgumentParser) -> None:
        p.add_argument("--loud", action="store_true")

    parser = argparse.ArgumentParser(prog="facesynth")
    sub = parser.add_subparsers(dest="command")
    found = iter([Command("greet", "say hello", greet, arguments, defaults={"kind": "test"})])
    add_commands(sub, found)
    args = parser.parse_args(["greet", "--loud"])
    assert args.handler(args) == 7
    assert "say hello" in sub.choices["greet"].format_help()
