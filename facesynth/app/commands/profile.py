"""``facesynth profile list|check|show``: written, hardware-only and learned profiles."""

from __future__ import annotations

import argparse
import logging
import sys

from facesynth.app.command_registry import Command
from facesynth.app.wiring import OptionError
from facesynth.runtime.profiles.learned import Learned, command_range

log = logging.getLogger("facesynth")


def cmd_profile(args: argparse.Namespace) -> int:
    """``facesynth profile list|check|show`` (written, hardware-only and learned profiles)."""

    from facesynth.runtime.profiles import (
        ProfileError,
        available_profiles,
        describe_learned,
        describe_source,
        has_source,
        load_profile,
    )

    if args.action == "list":
        for name in available_profiles(hardware=True):
            print(name)
        return 0
    if not args.name:
        raise OptionError(f"profile {args.action} needs a profile name or path")
    if args.action == "check":
        try:
            profile = load_profile(args.name)
        except ProfileError as exc:  # every problem, one line each, as the CLI's errors
            for problem in exc.problems:
                print(f"facesynth profile: error: {problem}", file=sys.stderr)
            return 2
        kind = ""
        if profile.learned is not None:
            kind = f"; {describe_learned(profile.learned)}"
        elif not any(has_source(spec) for spec in profile.servos):
            kind = "; hardware only: no sources, for facesynth learn and control"
        print(f"{args.name}: ok ({len(profile.servos)} servos{kind})")
        return 0
    profile = load_profile(args.name)
    learned = profile.learned
    if learned is not None:
        print(describe_learned(learned))
    print(
        f"{'ch':>3} {'servo':<20} {'min_us':>7} {'neutral':>7} {'max_us':>7} {'reversed':<8} source"
    )
    for spec in profile.servos:
        if learned is None:
            source = describe_source(spec)
        elif spec.name in learned.report.not_exercised:
            source = "learned: not exercised (never moved while babbling), kept at neutral"
        elif spec.name in learned.report.one_way:
            source = "learned: swept one way only, kept at neutral"
        elif spec.name in learned.dead:
            source = "learned: dead, kept at neutral"
        else:
            source = _learned_source(learned, spec.name)
        reversed_ = "reversed" if spec.reversed and learned is None else ""
        print(
            f"{spec.channel:>3} {spec.name:<20} {spec.min_us:>7g} {spec.neutral_us:>7g} "
            f"{spec.max_us:>7g} {reversed_:<8} {source}"
        )
    return 0


def _learned_source(learned: Learned, name: str) -> str:
    """A live learned servo's source column: its held-out errors, raw and effective (the
    goal's), and its responsive range when narrower than its travel."""
    error = learned.report.servo_error.get(name)
    effective = learned.report.effective_error.get(name)
    source = "learned" + (f": held-out error {error:.3f} of range" if error is not None else "")
    if effective is not None:
        source += f" (effective {effective:.3f})"
    low, high = command_range(learned)
    index = learned.outputs.index(name)
    if low[index] > -1.0 or high[index] < 1.0:
        source += f", responsive {low[index] + 0.0:+.2f} .. {high[index] + 0.0:+.2f}"
    return source


HELP = "list or check robot profiles"


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("action", choices=("list", "check", "show"))
    p.add_argument("name", nargs="?", help="profile name or TOML path (check, show)")


COMMANDS = (Command("profile", HELP, cmd_profile, _arguments),)
