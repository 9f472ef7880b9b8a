"""How big each message may be, checked on its bytes before anything decodes it.

One 18 MB servo command (a million-entry positions map) used to freeze a control interface for
2 s while msgspec built the map, and its memory stayed. Each key now has a payload limit, well
above what a valid message of its kind can weigh, applied twice:

* by the subscription (:meth:`facesynth.runtime.bus.base.Subscription.limit`), on the
  transport's thread, before the payload is even copied: an oversized message never reaches the
  service's event loop (the refusal is counted as rejected and logged);
* by :func:`facesynth.runtime.codec.decode`, for bytes from anywhere else (a recording, a test).

The sizes inside a message are bounded by what the limit leaves room for, then checked against
the profile (no more positions than servos) and the point schemes (:mod:`.codec`).

================  ============  =================================================================
key               limit         largest valid message
================  ============  =================================================================
``input``         40 MiB        a raw BGR frame of ``MAX_FRAME_PIXELS`` (37.7 MB); JPEGs are far
                                smaller, and their dimensions are read from their header before
                                anything decodes the pixels
``points``        256 KiB       478 3D points, 68 2D points, irises, 52 scores: about 25 KB
``features``      64 KiB        68 distances and deltas, 136 displacements, ~120 named: ~8 KB
``servo_*``       64 KiB        a profile's positions with the sender stamps: 16 servos ~0.6 KB
``babble``        64 KiB        one settled pose: 16 positions twice, ~120 features averaged
                                and their spread: ~8 KB
``stats``         16 KiB        one :class:`~facesynth.schemas.messages.ServiceStats`: ~0.3 KB
================  ============  =================================================================
"""

from __future__ import annotations

from typing import Final

from facesynth.runtime import keys

KIB: Final = 1024
MIB: Final = 1024 * KIB

#: The most pixels a frame may declare (a 4096 x 3072 sensor: 12.6 megapixels).
MAX_FRAME_PIXELS: Final = 4096 * 3072
#: The longest side a frame may declare (pixels).
MAX_FRAME_SIDE: Final = 8192

#: Payload limit (bytes) of each stage's key (and of the :data:`~keys.APP_KEYS`).
STAGE_LIMITS: Final[dict[str, int]] = {
    "input": 40 * MIB,
    "points": 256 * KIB,
    "features": 64 * KIB,
    "servo_commands": 64 * KIB,
    "servo_state": 64 * KIB,
    "babble": 64 * KIB,
}
#: Payload limit (bytes) of a service's stats message.
STATS_LIMIT: Final = 16 * KIB


#: What a Zenoh message carries beyond its payload (key expression, attachment, framing), and more.
MESSAGE_SLACK: Final = 64 * KIB


def session_limit(consumes: keys.Stage | None) -> int:
    """The largest Zenoh message a service consuming ``consumes`` accepts (bytes).

    Set as the session's ``transport/link/rx/max_message_size``: Zenoh then stops reassembling
    a bigger message at this size and drops it, instead of holding all of it in buffers that it
    keeps for reuse afterwards (measured: a subscriber's memory grew 40 MB after a burst of
    22 MB messages without it, and not at all with it). Every service also takes
    ``servo_state`` and stats messages.
    """
    largest = max(STAGE_LIMITS["servo_state"], STATS_LIMIT)
    if consumes is not None:
        largest = max(largest, STAGE_LIMITS[consumes])
    return largest + MESSAGE_SLACK


def router_limit() -> int:
    """The largest Zenoh message a router passes on (bytes): the largest limit of any key.

    Set as a router's ``transport/link/rx/max_message_size``, so the router stops reassembling
    anything no key accepts (Zenoh's default is 1 GiB); what is under it and over its own key's
    limit is dropped by the receiving session's :func:`session_limit` and screens.
    """
    return max(*STAGE_LIMITS.values(), STATS_LIMIT) + MESSAGE_SLACK


def stage_limit(stage: keys.DataKey) -> int:
    """The payload limit of ``stage``'s key, in bytes."""
    return STAGE_LIMITS[stage]
