"""Feature processor F, service shell: ``…/points`` → ``…/features``."""

from __future__ import annotations

from facesynth.runtime.service import ServiceContext, serve_transform
from schemas.messages import Points
from services.features.core import FeatureProcessor


async def serve_features(ctx: ServiceContext, processor: FeatureProcessor, queue: int = 8) -> None:
    """Compute features for every Points message until cancelled."""
    ctx.log.info("feature processor on %s", ctx.key("points"))
    await serve_transform(ctx, "points", Points, "features", processor.process, queue)
