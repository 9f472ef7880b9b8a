"""The live page's WebSocket messages, both ways (pure: bytes and text in and out).

Server to page, text (JSON objects with a ``type``):

* ``hello``: the profile, its controls (for the bars) and whether the face can be drawn;
* ``face``: one command: ``seq`` (the source frame, ``null`` for neutral), ``face`` (tracked),
  ``controls`` (name -> value) and ``shapes`` (the face's geometry, ``null`` for a profile
  that is not a face);
* ``points``: a frame's tracked 68 points, ``[x0, y0, x1, …]`` in frame pixels;
* ``stats``: one row per running service: rate, latency p50/p99, drops, status;
* ``pong``: the answer to a ``ping``.

Server to page, binary: a frame, as a 4-byte big-endian header length, the JSON header
(``seq``, ``width``, ``height``, ``encoding`` ``jpeg`` or ``raw`` BGR) and the pixels.

Page to server, text only, at most :data:`MAX_CLIENT_MESSAGE` bytes: ``{"type": "hello",
"frames": bool}`` (show the performer's frames or not) and ``{"type": "ping", "t": number}``.
Anything else is refused (:class:`ClientMessageError`) and the server closes that connection.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Mapping, Sequence
from typing import Literal

import msgspec

from facesynth.runtime.landmarks import IBUG68, N_IBUG
from facesynth.schemas.messages import Frame, Points, ServiceStats
from facesynth.services.control.drivers.virtual.geometry import Shape

#: The largest message a page may send (bytes); larger ones close the connection (1009).
MAX_CLIENT_MESSAGE = 1024

_encode = msgspec.json.Encoder().encode


class ClientMessageError(ValueError):
    """A message from a page that the server does not accept."""


class Hello(msgspec.Struct, tag="hello", tag_field="type", forbid_unknown_fields=True):
    """The page says which streams it shows."""

    frames: bool = True


class Ping(msgspec.Struct, tag="ping", tag_field="type", forbid_unknown_fields=True):
    """The page measures the round trip."""

    t: float


_client_decoder = msgspec.json.Decoder(Hello | Ping)


def parse_client(text: str) -> Hello | Ping:
    """A page's message, or raise :class:`ClientMessageError` (one line)."""
    size = len(text.encode("utf-8", "surrogatepass"))
    if size > MAX_CLIENT_MESSAGE:
        raise ClientMessageError(f"message of {size} bytes (limit {MAX_CLIENT_MESSAGE})")
    try:
        message = _client_decoder.decode(text)
    except (msgspec.DecodeError, msgspec.ValidationError, UnicodeError) as exc:
        raise ClientMessageError(f"not a hello or ping message: {exc}") from None
    if isinstance(message, Ping) and not math.isfinite(message.t):
        raise ClientMessageError("ping time is not a finite number")
    return message


def pong(ping: Ping) -> str:
    """The answer to a ping."""
    return _encode({"type": "pong", "t": ping.t}).decode()


class Control(msgspec.Struct):
    """One control, for the page's bars."""

    name: str
    low: float
    neutral: float
    high: float


def hello(profile: str, controls: Sequence[Control], draws_face: bool) -> str:
    """What the page needs to lay itself out."""
    return _encode(
        {"type": "hello", "profile": profile, "controls": controls, "face": draws_face}
    ).decode()


def face(
    seq: int | None,
    tracked: bool,
    controls: Mapping[str, float],
    shapes: list[Shape] | None,
    t_capture_ns: int | None,
) -> str:
    """One command, with the face's geometry."""
    return _encode(
        {
            "type": "face",
            "seq": seq,
            "face": tracked,
            "t_capture_ns": t_capture_ns,
            "controls": {name: round(value, 2) for name, value in controls.items()},
            "shapes": shapes,
        }
    ).decode()


def points(message: Points) -> str:
    """A frame's 68 points (empty when no face was tracked)."""
    coords: list[float] = []
    for point_set in message.sets:
        if point_set.scheme == IBUG68 and len(point_set.coords) == N_IBUG * point_set.dims:
            flat = point_set.coords
            coords = [round(flat[i * point_set.dims + k], 1) for i in range(N_IBUG) for k in (0, 1)]
            break
    return _encode(
        {
            "type": "points",
            "seq": message.seq,
            "face": message.face and bool(coords),
            "width": message.image_width,
            "height": message.image_height,
            "ibug68": coords,
        }
    ).decode()


def frame(message: Frame) -> bytes | None:
    """A frame as a binary message; ``None`` for a frame without pixels."""
    if message.encoding not in ("jpeg", "raw") or not message.data:
        return None
    header = _encode(
        {
            "seq": message.seq,
            "width": message.width,
            "height": message.height,
            "encoding": message.encoding,
        }
    )
    return struct.pack(">I", len(header)) + header + message.data


def read_frame(data: bytes) -> tuple[dict[str, object], bytes]:
    """The header and pixels of a binary frame message (the page's parser, for tests)."""
    (length,) = struct.unpack_from(">I", data)
    header = msgspec.json.decode(data[4 : 4 + length])
    return header, data[4 + length :]


StatusName = Literal["running", "silent", "stopped"]


class ServiceRow(msgspec.Struct):
    """One service's line in the page's status table."""

    service: str
    instance: str
    status: StatusName
    rate_hz: float
    p50_ms: float | None
    p99_ms: float | None
    received: int
    published: int
    dropped: int
    rejected: int
    #: Inputs dropped because their frame was captured longer ago than the stage's limit.
    stale: int = 0


class StatusBoard:
    """The newest stats of every service on the rig, and whether each is still alive.

    A service is ``running`` while its stats keep coming, ``silent`` when none came for
    ``silent_s`` seconds, ``stopped`` when its last stats said so (a clean stop).
    """

    def __init__(self, silent_s: float = 3.0) -> None:
        self.silent_ns = int(silent_s * 1e9)
        self._latest: dict[tuple[str, str], tuple[ServiceStats, int]] = {}

    def update(self, stats: ServiceStats, now_ns: int) -> None:
        """Remember a service's newest figures."""
        self._latest[(stats.service, stats.instance)] = (stats, now_ns)

    def rows(self, now_ns: int) -> list[ServiceRow]:
        """One row per service, in chain order then by instance."""
        order = {
            name: i
            for i, name in enumerate(("sensor", "points", "features", "translator", "control"))
        }
        rows = []
        for (service, instance), (s, seen) in sorted(
            self._latest.items(), key=lambda item: (order.get(item[0][0], 9), item[0])
        ):
            status: StatusName = "stopped" if s.note == "stopped" else "running"
            if status == "running" and now_ns - seen > self.silent_ns:
                status = "silent"
            rows.append(
                ServiceRow(
                    service=service,
                    instance=instance,
                    status=status,
                    rate_hz=round(s.rate_hz, 1),
                    p50_ms=None if s.latency_p50_ms is None else round(s.latency_p50_ms, 2),
                    p99_ms=None if s.latency_p99_ms is None else round(s.latency_p99_ms, 2),
                    received=s.received,
                    published=s.published,
                    dropped=s.dropped,
                    rejected=s.rejected,
                    stale=s.stale,
                )
            )
        return rows

    def message(self, now_ns: int) -> str:
        """The ``stats`` message for the page."""
        return _encode({"type": "stats", "services": self.rows(now_ns)}).decode()
