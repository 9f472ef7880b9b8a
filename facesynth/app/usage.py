"""Unknown options told by the sub-command that was given them, with a suggestion.

argparse hands options a sub-command does not know back to the top-level parser, which then
shows ``facesynth``'s own usage; :func:`parse_arguments` shows the sub-command's usage instead
(``facesynth run: error: unrecognized arguments: --profle x (did you mean --profile?)``), exit 2.
"""

from __future__ import annotations

import argparse
import difflib
from collections.abc import Sequence


def subcommand_parser(
    parser: argparse.ArgumentParser, name: str | None
) -> argparse.ArgumentParser | None:
    """The parser of sub-command ``name``, or None."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction) and name in action.choices:
            chosen: argparse.ArgumentParser = action.choices[name]
            return chosen
    return None


def suggestion(parser: argparse.ArgumentParser, unknown: Sequence[str]) -> str:
    """`` (did you mean --profile?)`` for the first unknown option close to one of ``parser``'s,
    else nothing."""
    options = [o for o in parser._option_string_actions if o.startswith("--")]
    for word in unknown:
        if word.startswith("-"):
            close = difflib.get_close_matches(word.split("=", 1)[0], options, n=1, cutoff=0.75)
            if close:
                return f" (did you mean {close[0]}?)"
    return ""


def parse_arguments(
    parser: argparse.ArgumentParser, argv: Sequence[str] | None = None
) -> argparse.Namespace:
    """``parser.parse_args(argv)``, but unknown options are an error of their sub-command."""
    args, unknown = parser.parse_known_args(argv)
    if unknown:
        owner = subcommand_parser(parser, getattr(args, "command", None)) or parser
        owner.error(f"unrecognized arguments: {' '.join(unknown)}{suggestion(owner, unknown)}")
    return args
