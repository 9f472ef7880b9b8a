"""Point streamer P, service shell: frames from ``…/input`` → landmarks on ``…/points``."""

from __future__ import annotations

from facesynth.runtime.capture_age import DEFAULT_MAX_AGE_S
from facesynth.runtime.service import ServiceContext, serve_transform
from facesynth.schemas.messages import Frame
from facesynth.services.points.backends import PointsBackend


async def serve_points(
    ctx: ServiceContext,
    backend: PointsBackend,
    queue: int = 2,
    max_age_s: float = DEFAULT_MAX_AGE_S,
) -> None:
    """Run ``backend`` on every frame until cancelled; a frame captured longer ago than
    ``max_age_s`` when its turn comes (after a stall) is dropped, not tracked (0: never)."""
    ctx.log.info("point streamer on %s (backend %s)", ctx.key("input"), backend.name)
    await serve_transform(
        ctx, "input", Frame, "points", backend.process, queue, max_age_s=max_age_s or None
    )
