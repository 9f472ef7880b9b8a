"""The console on the bus: the control interface C in this process, and the console's commands.

:class:`ConsoleSession` runs C (built by the caller, with the chosen driver and the profile's
file) as a node on the rig's bus and, while the page holds the servos, publishes the
:class:`~facesynth.app.console.rig.ConsoleRig`'s targets as ``ServoCommands`` on
``…/servo_commands`` ``RATE_HZ`` times a second, exactly as a translator would: C checks,
clamps and speed-limits them, and its watchdog returns the face to neutral when they stop (the
page closed, the console let go or died). It follows ``…/servo_state``, every service's stats
and the performer's frames and landmarks, and hands what it sees to a listener (the server).

Saving restarts C with the saved file: the face goes back to neutral (C's own shutdown), then
C starts again with the new limits.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import secrets
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from facesynth.app.chain import node_context
from facesynth.app.console.profile_file import save_profile
from facesynth.app.console.rig import ConsoleError, ConsoleRig
from facesynth.app.servo_sender import ServoSender
from facesynth.app.wiring import StageParts
from facesynth.runtime import codec
from facesynth.runtime.bus.base import Bus
from facesynth.runtime.profiles import load_profile
from facesynth.runtime.rig_view import RigView
from facesynth.runtime.service import ServiceContext, run_service
from facesynth.runtime.tasks import cancel_and_wait, stop_tasks
from facesynth.schemas.messages import Frame, Points, ServiceStats, ServoCommands

log = logging.getLogger("facesynth.console")

#: Commands per second while the console holds the servos (C's watchdog is 0.5 s by default).
RATE_HZ = 30.0
#: What a listener is told: ``(kind, payload)`` with kind ``state``, ``stats``, ``frame``,
#: ``points``, ``control`` (C's state changed) or ``error``.
Listener = Callable[[str, Any], None]
#: Builds C's node for a profile file.
ControlFactory = Callable[[str], StageParts]
#: Another service's servo command this recent (s) means something else drives the servos: the
#: console lets go and will not take them, rather than alternate with it in C.
ELSEWHERE_S = 1.0


class ConsoleSession:
    """C and the console's commands on one rig's bus (see the module docstring)."""

    def __init__(
        self,
        bus: Bus,
        rig: str,
        core: ConsoleRig,
        control: ControlFactory,
        *,
        profile_file: str,
        save_to: Path,
        stats_interval: float = 1.0,
        robot: str | None = None,
    ) -> None:
        self.bus = bus
        self.rig = rig
        self.core = core
        self.control = control
        self.profile_file = profile_file
        self.save_to = save_to
        self.stats_interval = stats_interval
        self.robot = robot
        self.control_state = "starting"
        self.listener: Listener = lambda kind, payload: None
        self.commands = ServoSender(f"console/{secrets.token_hex(3)}")
        self._c: asyncio.Task[Any] | None = None
        self._tasks: list[asyncio.Task[Any]] = []
        self._saving = asyncio.Lock()
        self._watching = asyncio.Event()
        self._following: dict[str, Any] = {}
        self._elsewhere: tuple[str, int] | None = None  # another sender, when last seen
        self._monotonic_ns: Callable[[], int] = time.monotonic_ns

    # --- life ---------------------------------------------------------------------------

    async def start(self) -> None:
        """Start C and the console's own service (commands, following the rig)."""
        self._start_control(self.profile_file)
        view = RigView(self.bus, self.rig)
        ctx = ServiceContext(
            self.bus, self.rig, "console", stats_interval=self.stats_interval, robot=self.robot
        )
        self._tasks = [
            asyncio.create_task(run_service(ctx, self._serve), name="console"),
            asyncio.create_task(self._follow_stats(view), name="console-stats"),
            asyncio.create_task(self._follow_latest(view, "input"), name="console-input"),
            asyncio.create_task(self._follow_latest(view, "points"), name="console-points"),
        ]

    async def stop(self) -> None:
        """Stop commanding, then stop C (which returns the face to neutral)."""
        self.core.release()
        try:
            await cancel_and_wait(self._tasks)
        finally:
            await self._stop_control()  # C too when this stop is cancelled meanwhile

    # --- requests -------------------------------------------------------------------------

    async def save(self) -> dict[str, Any]:
        """Save the draft profile (validated, atomic, with a backup); C restarts with it."""
        async with self._saving:
            draft = self.core.draft
            backup = save_profile(draft, self.save_to)
            saved = load_profile(str(self.save_to))  # what C will load: read back
            if saved != draft:
                raise ConsoleError(f"{self.save_to} did not read back as it was saved")
            self.core.release()
            self.control_state = "restarting"
            self.listener("control", self.control_state)
            await self._stop_control()
            self.core.saved(saved)
            self.profile_file = str(self.save_to)
            self._start_control(self.profile_file)
            log.info("profile %s saved to %s; C restarted with it", saved.name, self.save_to)
            return {"path": str(self.save_to), "backup": str(backup) if backup else None}

    def state(self) -> dict[str, Any]:
        """Where the servos are and are wanted, for the page."""
        return {
            "positions": [self.core.here(i) for i in range(len(self.core.targets))],
            "measured": [self.core.read_back(i)[0] for i in range(len(self.core.targets))],
            "faults": [self.core.read_back(i)[1] for i in range(len(self.core.targets))],
            "targets": list(self.core.targets),
            "holding": self.core.holding,
            "dirty": self.core.dirty,
            "control": self.control_state,
            "sent": self.commands.sent,
        }

    def driven_elsewhere(self) -> str | None:
        """The other sender of servo commands on this rig (a translator, another console's C
        client…) seen in the last :data:`ELSEWHERE_S`, or None."""
        if self._elsewhere is None:
            return None
        sender, seen_ns = self._elsewhere
        return sender if self._monotonic_ns() - seen_ns < ELSEWHERE_S * 1e9 else None

    def check_free(self) -> None:
        """Refuse to move servos (``ConsoleError``) while another sender drives them."""
        sender = self.driven_elsewhere()
        if sender is not None:
            raise ConsoleError(
                f"{sender} is sending servo commands on this rig: stop it before moving the "
                "servos from the console"
            )

    # --- C ----------------------------------------------------------------------------------

    def _start_control(self, profile_file: str) -> None:
        part = self.control(profile_file)
        ctx = node_context(self.bus, self.rig, part, self.stats_interval)
        self._c = asyncio.create_task(run_service(ctx, part.body), name="control")
        self._c.add_done_callback(self._control_ended)
        self.control_state = "running"
        self.listener("control", self.control_state)

    def _control_ended(self, task: asyncio.Task[Any]) -> None:
        if task is not self._c or task.cancelled():
            return
        error = task.exception()
        self.core.release()
        self.control_state = f"stopped: {error}" if error else "stopped"
        log.error("the control interface stopped: %s", error or "it ended")
        self.listener("control", self.control_state)
        self.listener("error", f"the control interface stopped: {error or 'it ended'}")

    async def _stop_control(self) -> None:
        task, self._c = self._c, None
        if task is not None and not task.done():
            await cancel_and_wait([task])

    # --- the console's service ------------------------------------------------------------------

    async def _serve(self, ctx: ServiceContext) -> None:
        states = ctx.subscribe("servo_state", 4, ServoCommands)
        commands = ctx.subscribe("servo_commands", 4, ServoCommands)
        self._monotonic_ns = ctx.clock.monotonic_ns
        ctx.ready()
        followers = [
            asyncio.create_task(self._follow_states(states)),
            asyncio.create_task(self._follow_senders(commands)),
        ]
        started = ctx.clock.monotonic_ns()
        try:
            while True:
                elsewhere = self.driven_elsewhere()
                if self.core.holding and elsewhere is not None:
                    self.core.release()
                    self.listener(
                        "error",
                        f"{elsewhere} started sending servo commands on this rig: the console "
                        "let go of the servos",
                    )
                if self.core.holding and self.control_state == "running":
                    self.commands.send(
                        ctx,
                        self.core.commands(),
                        face=True,
                        profile=self.core.active.name,
                        started_ns=started,
                    )
                self.listener("state", self.state())
                await ctx.clock.sleep(1 / RATE_HZ)
        finally:
            await stop_tasks(followers)

    async def _follow_states(self, subscription: Any) -> None:
        async for sample in subscription:
            state = sample.message
            if isinstance(state, ServoCommands):
                self.core.report(state.profile, state.positions, state.measured, state.faults)

    async def _follow_senders(self, subscription: Any) -> None:
        async for sample in subscription:
            command = sample.message
            if isinstance(command, ServoCommands) and command.sender != self.commands.sender:
                self._elsewhere = (command.sender or "another service", self._monotonic_ns())

    async def _follow_stats(self, view: RigView) -> None:
        subscription = view.stats()
        try:
            async for sample in subscription:
                with contextlib.suppress(ValueError):
                    stats = codec.decode(sample.payload, ServiceStats)
                    self.listener("stats", (stats, time.time_ns()))
        finally:
            subscription.close()

    @property
    def watching(self) -> bool:
        """Whether the performer's frames and landmarks are followed (a page shows them)."""
        return self._watching.is_set()

    def watch(self, wanted: bool) -> None:
        """Follow the performer's frames and landmarks only while a page shows them."""
        if wanted:
            self._watching.set()
            return
        self._watching.clear()
        for subscription in list(self._following.values()):
            subscription.close()  # its follower waits for a page again

    async def _follow_latest(self, view: RigView, stage: Any) -> None:
        while True:
            await self._watching.wait()
            subscription = view.latest(stage)
            self._following[stage] = subscription
            try:
                await self._forward(stage, subscription)
            finally:
                subscription.close()
                self._following.pop(stage, None)

    async def _forward(self, stage: Any, subscription: Any) -> None:
        async for sample in subscription:
            with contextlib.suppress(ValueError):
                if stage == "input":
                    self.listener("frame", codec.decode(sample.payload, Frame))
                else:
                    self.listener("points", codec.decode(sample.payload, Points))
