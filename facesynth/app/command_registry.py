"""The ``facesynth`` commands, registered like plugins.

A command is one module that exports ``COMMANDS``: a :class:`Command` (a few modules export a
family, such as the five stage commands) giving its name, one-line help, how it declares its
arguments and what runs it. A family read from another registry is exported as a function
returning the commands, called each time the parser is built: the stage commands are those of
the stages registered then (:data:`facesynth.app.stages.registry.STAGES`), a stage registered
after import included. :data:`COMMAND_MODULES` lists those modules once, in the order
``facesynth --help`` shows them; the parser (:mod:`facesynth.app.cli`) and every tool that
needs the list of commands read it from here.
"""

from __future__ import annotations

import argparse
import importlib
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

Handler = Callable[[argparse.Namespace], int]

#: The modules that export ``COMMANDS`` (commands, or a function giving them), in ``--help``
#: order.
COMMAND_MODULES = (
    "facesynth.app.commands.run",
    "facesynth.app.commands.stage",
    "facesynth.app.commands.render",
    "facesynth.app.commands.compose",
    "facesynth.app.commands.certs",
    "facesynth.app.commands.calibrate",
    "facesynth.app.commands.firmware",
    "facesynth.app.commands.router",
    "facesynth.app.commands.status",
    "facesynth.app.commands.profile",
    "facesynth.app.commands.bench",
    "facesynth.app.commands.track",
    "facesynth.app.commands.plan",
    "facesynth.app.recording.cli",
    "facesynth.app.learn.arguments",
    "facesynth.app.simhead.command",
    "facesynth.app.doctor.command",
    "facesynth.app.console.arguments",
)


@dataclass(frozen=True)
class Command:
    """One ``facesynth`` sub-command."""

    #: What the user types (``facesynth NAME``).
    name: str
    #: One line: the sub-command's help in ``facesynth --help`` and its description.
    help: str
    #: Runs the command; returns the exit status (errors raise, see :func:`facesynth.app.cli.main`).
    run: Handler
    #: Declares the command's arguments on its own parser.
    arguments: Callable[[argparse.ArgumentParser], None]
    #: Values the parsed arguments carry without a flag (a stage command's ``stage``).
    defaults: Mapping[str, Any] = field(default_factory=dict)


def commands(modules: tuple[str, ...] = COMMAND_MODULES) -> Iterator[Command]:
    """Every registered command, in ``--help`` order; a name given twice is an error."""
    seen: dict[str, str] = {}
    for module_name in modules:
        exported = importlib.import_module(module_name).COMMANDS
        for command in exported() if callable(exported) else exported:
            if command.name in seen:
                raise ValueError(
                    f"command {command.name!r} is registered by {seen[command.name]} "
                    f"and by {module_name}"
                )
            seen[command.name] = module_name
            yield command


def add_commands(sub: Any, found: Iterator[Command] | None = None) -> None:
    """Declare each command on the main parser's sub-parsers."""
    for command in commands() if found is None else found:
        parser: argparse.ArgumentParser = sub.add_parser(
            command.name, help=command.help, description=command.help
        )
        parser.set_defaults(handler=command.run, **command.defaults)
        command.arguments(parser)
