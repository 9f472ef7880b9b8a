"""Servo commands that a tool publishes itself, stamped as a translator stamps its own.

The rig console (a page jogging the servos) and ``facesynth learn`` (the babbler) publish
``ServoCommands`` on the rig's ``…/servo_commands`` themselves, so that the control
interface's clamping, speed and acceleration limits, freshness checks and watchdog all hold for
them. :class:`ServoSender` numbers a tool's commands from 1 (``seq`` and ``sender_seq``),
stamps each with the wall clock when it is sent (``t_capture_ns`` and ``sent_ns``), the
sender's name and the name of this host's clock
(:func:`~facesynth.runtime.clock_host.clock_host`), and ``t_media_ns`` with the time since
the tool started.
"""

from __future__ import annotations

from facesynth.runtime.clock_host import clock_host
from facesynth.runtime.service import ServiceContext
from facesynth.schemas.messages import ServoCommands


class ServoSender:
    """One tool's stamped servo commands (see the module docstring)."""

    def __init__(self, sender: str = "") -> None:
        self.sender = sender
        self.host = clock_host()
        self.sent = 0

    def send(
        self,
        ctx: ServiceContext,
        positions: dict[str, float],
        *,
        face: bool,
        profile: str,
        started_ns: int,
    ) -> None:
        """Publish ``positions`` (for ``profile``) on ``…/servo_commands``; ``started_ns`` is
        the tool's start on ``ctx``'s monotonic clock."""
        self.sent += 1
        now_ns = ctx.clock.time_ns()
        ctx.publish(
            "servo_commands",
            ServoCommands(
                seq=self.sent,
                t_capture_ns=now_ns,
                t_media_ns=max(0, ctx.clock.monotonic_ns() - started_ns),
                face=face,
                profile=profile,
                positions=positions,
                sender=self.sender,
                sender_seq=self.sent,
                sent_ns=now_ns,
                sender_host=self.host,
            ),
        )
