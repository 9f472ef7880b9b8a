"""Translator T, service shell: ``…/features`` → ``…/servo_commands``."""

from __future__ import annotations

from facesynth.runtime.service import ServiceContext, serve_transform
from schemas.messages import Features
from services.translator.core import Translator


async def serve_translator(ctx: ServiceContext, translator: Translator, queue: int = 8) -> None:
    """Translate every Features message until cancelled."""
    ctx.log.info("translator on %s (profile %s)", ctx.key("features"), translator.profile.name)
    await serve_transform(ctx, "features", Features, "servo_commands", translator.translate, queue)
