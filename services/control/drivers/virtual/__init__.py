"""The ``virtual`` driver: a live web page drawing the virtual face, at the command rate.

``--driver virtual [--http HOST:PORT]`` serves a page (default http://127.0.0.1:8080/) that
draws the face of the ``virtual`` profile's controls (:mod:`.geometry`, computed here once per
command and sent to every page), bars for every control of any profile, and, from the rig, the
performer's frame with the tracked landmarks and each stage's rate, latency and status. The page
is plain HTML and JavaScript shipped in ``static/`` (no build step, nothing from the internet)
and reconnects by itself when the service restarts.

aiohttp comes with the ``[face]`` extra and is imported only when this driver is built.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from typing import TYPE_CHECKING, Annotated

import msgspec

from facesynth.runtime.profiles import Profile, load_profile
from facesynth.runtime.rig_view import RigView
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers._extras import require
from facesynth.services.control.drivers.base import DriverConfigError, DriverError, ServoDriver
from facesynth.services.control.drivers.registry import DRIVERS
from facesynth.services.control.drivers.servo_map import ProfileLimits
from facesynth.services.control.drivers.virtual import wire
from facesynth.services.control.drivers.virtual.geometry import draws_face, face_geometry

if TYPE_CHECKING:
    from facesynth.services.control.drivers.virtual.server import PageServer

DEFAULT_HTTP = "127.0.0.1:8080"

log = logging.getLogger("facesynth.control")


class AddressError(ValueError):
    """An ``--http`` address that is not HOST:PORT."""


class VirtualConfig(
    msgspec.Struct, tag="virtual", tag_field="driver", kw_only=True, forbid_unknown_fields=True
):
    """Draw the virtual face live on a web page (servo bars for any profile)."""

    http: Annotated[
        str,
        msgspec.Meta(
            description="serve the live face page on HOST:PORT (default 127.0.0.1:8080; "
            "port 0 = any free port)",
            extra={"flag": "--http"},
        ),
    ] = DEFAULT_HTTP
    frames: Annotated[
        bool,
        msgspec.Meta(
            description="show the performer's frames and landmarks from the bus beside the face",
            extra={"flag": "--page-frames"},
        ),
    ] = True
    max_clients: Annotated[
        int, msgspec.Meta(ge=1, le=256, description="pages open at once (default 16)")
    ] = 16


def parse_address(text: str) -> tuple[str, int]:
    """``(host, port)`` from ``HOST:PORT`` (``[::1]:8080`` for IPv6)."""
    host, sep, port = text.rpartition(":")
    host = host.strip("[]")
    digits = port.isascii() and port.isdigit()  # "²".isdigit() is true, int("²") fails
    if not sep or not host or not digits or not 0 <= int(port) <= 65535:
        raise AddressError(f"--http: expected HOST:PORT (e.g. {DEFAULT_HTTP}), got {text!r}")
    return host, int(port)


@DRIVERS.register(VirtualConfig)
class VirtualDriver(ServoDriver):
    """Draw the virtual face live on a web page (servo bars for any profile)."""

    moves_hardware = False
    expected_profile = "virtual"
    needs_extra = "face"

    def __init__(self, config: VirtualConfig, profile: Profile | None = None) -> None:
        require("aiohttp", plugin="virtual driver", package="aiohttp", extra="face")
        self.config = config
        self.host, self.port = parse_address(config.http)
        self.profile = profile if profile is not None else load_profile("virtual")
        self.limits = ProfileLimits(self.profile)
        names = [spec.name for spec in self.profile.servos]
        self.draws_face = draws_face(names)
        controls = [
            wire.Control(s.name, s.min_us, s.neutral_us, s.max_us)
            for s in sorted(self.profile.servos, key=lambda s: s.channel)
        ]
        self.hello = wire.hello(self.profile.name, controls, self.draws_face)
        self.server: PageServer | None = None
        self._rig: RigView | None = None
        self.count = 0

    @property
    def url(self) -> str:
        """The page's address (the real port once connected)."""
        if self.server is not None:
            return self.server.url
        return f"http://{self.host}:{self.port}/"

    def observe(self, rig: RigView) -> None:
        self._rig = rig

    async def connect(self) -> None:
        from facesynth.services.control.drivers.virtual.server import PageServer

        server = PageServer(
            self.host,
            self.port,
            self.hello,
            rig=self._rig,
            frames=self.config.frames,
            max_clients=self.config.max_clients,
        )
        try:
            await server.start()
        except OSError as exc:  # a usage error like a bad flag (exit 2), with the flag to change
            raise DriverConfigError(
                f"cannot serve the live face page on {self.config.http}: {exc} - choose another "
                "address with --http HOST:PORT (port 0 picks a free one)"
            ) from None
        self.server = server
        what = "the face" if self.draws_face else f"bars of {self.profile.name}"
        log.info("live face page on %s (%s)", server.url, what)

    async def send(self, positions: Mapping[str, float], info: CommandInfo) -> None:
        if self.server is None:
            raise DriverError("virtual driver is not connected")
        positions = self.limits.clamp(positions)
        shapes = face_geometry(positions) if self.draws_face else None
        self.server.publish_face(
            wire.face(info.frame, info.face, positions, shapes, info.t_capture_ns)
        )
        self.count += 1

    async def close(self) -> None:
        if self.server is not None:
            server, self.server = self.server, None
            await server.stop()
