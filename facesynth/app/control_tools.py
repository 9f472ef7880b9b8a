"""``facesynth control test|status``: bring-up tools for a servo board, run without the bus.

``test`` moves one servo (``--servo NAME``) or each in turn (``--all``) slowly from neutral to
each limit and back (at ``--speed``, never above the servo's ``max_speed``), the others held at
neutral, printing where it is; ``status`` prints what
the board reports (the firmware's counters, the Maestro's error register, positions). Both
take the control node's options (``--driver``, ``--port``, ``--profile``, ``--graph``), open
the board once (a clear error if it is not there) and leave it at neutral.
"""

from __future__ import annotations

import argparse
import asyncio
import time
from collections.abc import Callable
from typing import Any

from facesynth.app.graph import Graph, load_graph, select_node
from facesynth.app.nodes import ControlNode
from facesynth.app.profile_choice import check_fit, settle_profiles
from facesynth.app.stage_args import apply_arguments
from facesynth.app.wiring import OptionError, build_profile
from facesynth.runtime.profiles import Profile
from facesynth.runtime.service import run_async
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.base import DeviceUnavailable, ServoDriver
from facesynth.services.control.drivers.registry import DRIVERS
from facesynth.services.control.sweep import sweep

#: Steps per second of a sweep.
SWEEP_RATE_HZ = 50
#: Seconds between progress lines during a sweep.
PROGRESS_S = 0.5
TEST_OPTIONS = ("servo", "all_servos", "speed", "hold")


def add_tool_arguments(parser: argparse.ArgumentParser) -> None:
    """``ACTION`` (test, status) and the options of ``test``, on the control command."""
    parser.add_argument(
        "action",
        nargs="?",
        choices=("test", "status"),
        help="bring-up tools instead of the service: test (move servos slowly to their "
        "limits and back), status (what the board reports)",
    )
    group = parser.add_argument_group("control test")
    group.add_argument("--servo", metavar="NAME", help="test: the servo to move")
    group.add_argument(
        "--all", dest="all_servos", action="store_true", help="test: every servo, one at a time"
    )
    group.add_argument(
        "--speed", type=float, metavar="US_PER_S", help="test: sweep speed in us/s (default 250)"
    )
    group.add_argument(
        "--hold", type=float, metavar="S", help="test: seconds to hold each limit (default 0.5)"
    )


def cmd_control_tool(args: argparse.Namespace) -> int:
    """``facesynth control test|status``."""
    given = [name for name in TEST_OPTIONS if getattr(args, name, None) not in (None, False)]
    if args.action is None:
        if given:
            raise OptionError(f"--{given[0].replace('_servos', '')} needs `facesynth control test`")
        raise OptionError("no action")  # pragma: no cover - cmd_stage runs the service instead
    node = _control_node(args)
    node, config = apply_arguments("control", node, args)
    settle_profiles(Graph(nodes={"control": node}), {"control": config})
    profile = build_profile(node.profile, node.mirror)
    check_fit(config, profile)
    driver = DRIVERS.build(config, profile)
    if args.action == "status":
        if given:
            raise OptionError(f"--{given[0].replace('_servos', '')} is an option of test")
        return run_async(show_status(driver))
    names = _servos(profile, args)
    speed = 250.0 if args.speed is None else args.speed
    hold = 0.5 if args.hold is None else args.hold
    if not speed > 0 or hold < 0:
        raise OptionError("--speed must be > 0 and --hold >= 0")
    return run_async(run_test(driver, profile, names, speed=speed, hold=hold))


def _control_node(args: argparse.Namespace) -> ControlNode:
    if args.graph:
        graph = load_graph(args.graph, plugins=False)
        node = select_node(graph, "control", args.node, args.graph)
        assert isinstance(node, ControlNode)
        return node
    if args.node:
        raise OptionError("--node needs --graph")
    return ControlNode()


def _servos(profile: Profile, args: argparse.Namespace) -> list[str]:
    names = [spec.name for spec in profile.servos]
    if args.all_servos == bool(args.servo):
        raise OptionError("test needs --servo NAME or --all")
    if args.all_servos:
        return names
    if args.servo not in names:
        raise OptionError(
            f"profile {profile.name!r} has no servo {args.servo!r} (servos: {', '.join(names)})"
        )
    return [args.servo]


async def show_status(driver: ServoDriver, out: Callable[[str], None] = print) -> int:
    """Open the board, print what it reports, close it."""
    await driver.connect_once(query_only=True)
    try:
        report = await driver.device_status()
    except TimeoutError as exc:
        raise DeviceUnavailable(str(exc) or "the board does not answer") from None
    finally:
        await driver.close()
    out(format_report(report))
    return 0


def format_report(report: dict[str, Any]) -> str:
    """``key  value`` lines; a mapping becomes one indented line per item."""
    width = max(len(key) for key in report)
    lines = []
    for key, value in report.items():
        if isinstance(value, dict):
            lines.append(key)
            inner = max((len(str(k)) for k in value), default=0)
            lines += [f"  {k:<{inner}}  {v}" for k, v in value.items()]
        elif isinstance(value, list):
            lines.append(f"{key:<{width}}  {', '.join(str(v) for v in value) or '-'}")
        else:
            lines.append(f"{key:<{width}}  {value}")
    return "\n".join(lines)


async def run_test(
    driver: ServoDriver,
    profile: Profile,
    names: list[str],
    *,
    speed: float,
    hold: float,
    rate_hz: float = SWEEP_RATE_HZ,
    out: Callable[[str], None] = print,
) -> int:
    """Sweep each named servo in turn; the face is left at neutral, even when interrupted."""
    neutral = profile.neutral_positions()
    info = CommandInfo(frame=None, t_capture_ns=None, face=False)
    await driver.connect_once()
    try:
        await driver.neutral(neutral)
        for name in names:
            spec = profile.servo(name)
            # Never faster than the profile allows (the firmware would hold it back anyway).
            pace = min(speed, spec.max_speed) if spec.max_speed > 0 else speed
            out(
                f"{name} (channel {spec.channel}): {spec.min_us:g} .. {spec.neutral_us:g} .. "
                f"{spec.max_us:g} us, {pace:g} us/s"
            )
            period = 1 / rate_hz
            start = time.monotonic()
            shown = start
            for i, step in enumerate(sweep(spec, pace, rate_hz, hold)):
                await driver.send({**neutral, name: step.position}, info)
                now = time.monotonic()
                if step.arrived and not step.leg.startswith("hold"):
                    out(f"  {name} at {step.position:g} us ({step.leg})")
                    shown = now
                elif now - shown >= PROGRESS_S:
                    out(f"  {name} {step.position:.0f} us")
                    shown = now
                await asyncio.sleep(max(0.0, start + (i + 1) * period - time.monotonic()))
        out("done: every servo at neutral")
    finally:
        await driver.neutral(neutral)
        await driver.close()
    return 0
