"""Point streamer P, service shell: frames from ``…/input`` → landmarks on ``…/points``."""

from __future__ import annotations

from facesynth.runtime.service import ServiceContext, serve_transform
from schemas.messages import Frame
from services.points.backends import PointsBackend


async def serve_points(ctx: ServiceContext, backend: PointsBackend, queue: int = 2) -> None:
    """Run ``backend`` on every frame until cancelled."""
    ctx.log.info("point streamer on %s (backend %s)", ctx.key("input"), backend.name)
    await serve_transform(ctx, "input", Frame, "points", backend.process, queue)
