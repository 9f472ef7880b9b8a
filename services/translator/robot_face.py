"""T's closed loop on the bus: the robot's own face read before each command, and what the loop
learns kept beside the learned profile.

The robot's camera runs as a chain of its own (a sensor on the camera, points, features) on
another rig, as ``facesynth learn`` runs it (rig ``self``): its ``…/features`` is the robot's
face as the same tracker and F see it, stamped with the camera's capture time. T reads what
waits there just before each command (:meth:`RobotFaceFeed.catch_up`, no event-loop wake-up
per frame, as it reads ``…/servo_state``) and hands it to
:meth:`~facesynth.services.translator.core.Translator.observe`; the loop
(:mod:`facesynth.services.translator.closed_loop`) needs the translator closed first
(:meth:`~facesynth.services.translator.core.Translator.close_loop`). The application's
``--robot-camera`` tracks the camera in T's own process instead and hands its faces over
(:class:`LocalFaces`, read the same way; its camera failing or stopping is logged once per
cause, and the loop stays open meanwhile). What the loop learned is
written atomically every ``save_every_s`` (in a worker thread) and when the service stops
(:mod:`facesynth.services.translator.loop_state`).
"""

from __future__ import annotations

import asyncio
import copy
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

from facesynth.runtime import codec, limits
from facesynth.runtime.bus.base import Subscription
from facesynth.runtime.service import ServiceContext
from facesynth.schemas.messages import Features
from facesynth.services.translator.closed_loop import ClosedLoop
from facesynth.services.translator.core import Translator
from facesynth.services.translator.loop_state import save_loop_state

__all__ = ["LocalFaces", "RobotFace", "RobotFaceFeed"]

#: The robot's faces kept between two performer frames (the oldest dropped beyond).
FACE_QUEUE = 8


class LocalFaces(Protocol):
    """The robot's faces tracked in this process (the application's ``--robot-camera``)."""

    error: str | None

    def faces(self) -> list[Features]:
        """The faces tracked since the last call, oldest first."""

    def close(self) -> None:
        """Stop tracking."""


@dataclass(frozen=True)
class RobotFace:
    """Where T sees the robot's face: ``key`` (the robot camera's ``…/features``) or, with
    ``local``, faces tracked in this process (``local()`` starts them when the service
    starts); and where what the loop learns is kept (``state_path``; None: not kept), every
    ``save_every_s``."""

    key: str | None
    state_path: Path | None = None
    save_every_s: float = 60.0
    local: Callable[[], LocalFaces] | None = None


def _decode(payload: bytes) -> Features:
    return codec.decode(payload, Features)


class RobotFaceFeed:
    """The robot's faces on the bus, into a closed translator."""

    def __init__(
        self, ctx: ServiceContext, translator: Translator, loop: ClosedLoop, face: RobotFace
    ) -> None:
        self.ctx, self.translator, self.loop, self.face = ctx, translator, loop, face
        self.subscription: Subscription | None = None
        if face.key is not None:
            self.subscription = ctx.bus.subscribe_queued(face.key, FACE_QUEUE)
            self.subscription.guard(limits.stage_limit("features"), _decode)
            self.subscription.poll_only()
        self.local = face.local() if face.local is not None else None
        self.said: str | None = None
        self.seen = 0

    def catch_up(self) -> None:
        """Every face waiting, in order, to the translator (a malformed one never arrives)."""
        if self.local is not None:
            for features in self.local.faces():
                self.translator.observe(features)
                self.seen += 1
            error = self.local.error
            if error is not None and error != self.said:
                self.ctx.log.warning("%s: the loop stays open", error)
            elif error is None and self.said is not None:
                self.ctx.log.info("the robot's camera delivers again")
            self.said = error
        if self.subscription is None:
            return
        while (sample := self.subscription.receive_nowait()) is not None:
            if isinstance(sample.message, Features):
                self.translator.observe(sample.message)
                self.seen += 1

    def save(self) -> None:
        """Write what the loop learned now (nothing without a ``state_path``)."""
        learned = self.translator.profile.learned
        if self.face.state_path is None or learned is None:
            return
        save_loop_state(
            self.loop.state, self.translator.profile.name, learned, self.face.state_path
        )

    async def keep(self) -> None:
        """Save every ``save_every_s`` until cancelled (a copy, written in a worker thread)."""
        learned = self.translator.profile.learned
        if self.face.state_path is None or learned is None:
            return
        while True:
            await self.ctx.clock.sleep(self.face.save_every_s)
            state = copy.deepcopy(self.loop.state)
            name, path = self.translator.profile.name, self.face.state_path
            try:
                await asyncio.to_thread(save_loop_state, state, name, learned, path)
            except OSError as exc:
                self.ctx.log.warning("could not keep the loop's state in %s: %s", path, exc)

    def close(self) -> None:
        """Stop reading and keep what was learned."""
        if self.subscription is not None:
            self.subscription.close()
        if self.local is not None:
            self.local.close()
        try:
            self.save()
        except OSError as exc:
            self.ctx.log.warning(
                "could not keep the loop's state in %s: %s", self.face.state_path, exc
            )
