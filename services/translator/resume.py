"""Where a translator resumes from, and the stamps on its commands: pure, time as data.

Before its first command, and again once the control interface has moved on its own (it
started, returned to neutral after commands stopped reaching it, stopped, or reports being idle:
anything but following commands), the translator learns where the servos are from
``…/servo_state`` and resumes from there (:meth:`Translator.resume`), so its next command never
asks for a jump. With no report yet it starts from neutral, where a controller starts, and an
idle controller reports where it is every half second, which the translator then takes. While
the controller follows its commands (or catches up with them within the speed limits) it is
where this translator left it, so a pause in the input alone changes nothing. (It never waits
for a report: a real-time stream would lose frames meanwhile. Until it has one, the
controller's own speed limits keep any difference from becoming a jump.)

Every command is stamped for the controller's freshness checks: ``sender`` (the service's
instance and a token of this start), ``sender_seq`` (1, 2, …), ``sent_ns`` (wall clock) and
``sender_host``.
"""

from __future__ import annotations

import msgspec

from facesynth.runtime.bus.base import Subscription
from facesynth.schemas.messages import Features, ServoCommands
from facesynth.services.translator.core import Translator

#: Moves on ``…/servo_state`` during which the controller follows a sender's commands.
FOLLOWING = ("command", "catch-up")


class ServoStateWatch:
    """The newest positions the control interface reported for one profile, and whether it
    moved on its own since :meth:`take` was last called."""

    def __init__(self, profile: str) -> None:
        self.profile = profile
        self.positions: dict[str, float] | None = None
        self.moved_on_its_own = False

    def see(self, state: ServoCommands) -> None:
        """One ``…/servo_state`` message (another profile's is ignored)."""
        if state.profile != self.profile:
            return
        self.positions = dict(state.positions)
        if state.move not in FOLLOWING:
            self.moved_on_its_own = True

    def take(self) -> dict[str, float] | None:
        """The positions to resume from (``None``: never reported); clears ``moved_on_its_own``."""
        self.moved_on_its_own = False
        return self.positions

    def catch_up(self, subscription: Subscription) -> None:
        """Every report waiting in ``subscription`` (screened on arrival), in order: the
        translator reads them just before each command instead of waking for each one."""
        while (sample := subscription.receive_nowait()) is not None:
            if sample.message is not None:
                self.see(sample.message)


class ResumingTranslator:
    """A :class:`Translator` that resumes from the reported servos and stamps its commands.

    ``resumed`` says, after each :meth:`translate`, what it resumed from on that call:
    ``"reported"`` or ``"neutral"`` (no report yet), else ``None``.
    """

    def __init__(self, translator: Translator, *, sender: str, host: str) -> None:
        self.translator = translator
        self.watch = ServoStateWatch(translator.profile.name)
        self.sender = sender
        self.host = host
        self.sent = 0
        self.started = False
        self.resumed: str | None = None

    def translate(self, features: Features, now_ns: int) -> ServoCommands:
        """The stamped command for ``features`` sent at ``now_ns`` (wall clock); raises
        ``ValueError`` for features it cannot use."""
        self.resumed = None
        if not self.started or self.watch.moved_on_its_own:
            positions = self.watch.take()
            where = positions if positions is not None else self.translator.neutral()
            if not self.started or not self.translator.is_at(where):
                self.translator.resume(where)
                self.resumed = "reported" if positions is not None else "neutral"
            self.started = True
        commands = self.translator.translate(features, now_ns)
        self.sent += 1
        return msgspec.structs.replace(
            commands,
            sender=self.sender,
            sender_seq=self.sent,
            sent_ns=now_ns,
            sender_host=self.host,
        )
