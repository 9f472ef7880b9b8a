"""The ``dynamixel`` driver: ROBOTIS Dynamixel servos on one bus (Protocol 2.0 or 1.0).

At every connect it pings each servo of the profile (``bus_id``, default channel + 1), checks
the model number against the profile's ``model``, converts the limits to native units,
sets Profile Velocity/Acceleration (Moving Speed, Goal Acceleration on 1.0) from
``max_speed``/``max_accel`` and turns the torque on. Each pose is one Sync Write of Goal
Position; present position, load and temperature come back by Sync Read (Protocol 2.0) or
READ (1.0) within ``--bus-read-ms`` of bus time a read-back, ``--bus-read-hz`` read-backs
a second. See :mod:`..bus_servo`.
"""

from __future__ import annotations

import logging
from typing import Annotated, Literal

import msgspec

from facesynth.runtime.profiles import Profile
from facesynth.services.control.drivers._extras import require
from facesynth.services.control.drivers.bus_servo.bus import ServoBus
from facesynth.services.control.drivers.bus_servo.driver import AtExit, BusServoDriver
from facesynth.services.control.drivers.bus_servo.models import check_profile_models
from facesynth.services.control.drivers.bus_servo.options import (
    AtExitField,
    Latency,
    ReadBudget,
    ReadRate,
)
from facesynth.services.control.drivers.dynamixel.bus import DynamixelBus
from facesynth.services.control.drivers.dynamixel.models import BY_NAME
from facesynth.services.control.drivers.registry import DRIVERS
from facesynth.services.control.drivers.serial_link import PORT_HELP, check_port

log = logging.getLogger("facesynth.control.dynamixel")

#: Factory baud rates: X series 57600, AX-12A and MX (1.0) 1000000.
FACTORY_BAUD = {2: 57600, 1: 1000000}


class DynamixelConfig(
    msgspec.Struct, tag="dynamixel", tag_field="driver", kw_only=True, forbid_unknown_fields=True
):
    """ROBOTIS Dynamixel servos on one bus (U2D2 or any half-duplex TTL/RS-485 adapter)."""

    port: Annotated[str, msgspec.Meta(description=PORT_HELP)]
    baud: (
        Annotated[
            int,
            msgspec.Meta(
                gt=0,
                description="baud rate (default: the profile's [bus] baud, else the factory "
                "setting: 57600 for Protocol 2.0, 1000000 for 1.0)",
            ),
        ]
        | None
    ) = None
    protocol: Annotated[
        Literal[1, 2] | None,
        msgspec.Meta(
            description="Dynamixel protocol 1 (AX, MX) or 2 (X series; default: the "
            "profile's [bus] protocol, else 1 when every servo's model is a 1.0 one, else 2)",
            extra={"flag": "--dynamixel-protocol"},
        ),
    ] = None
    read_budget_ms: ReadBudget = 2.0
    read_hz: ReadRate | None = None
    latency_ms: Latency = 16.0
    at_exit: AtExitField = "hold"


def choose_protocol(config: DynamixelConfig, profile: Profile) -> int:
    """The protocol: the option, the profile's ``[bus]``, else from the servos' models."""
    if config.protocol is not None:
        return config.protocol
    if profile.bus is not None and profile.bus.protocol is not None:
        return profile.bus.protocol
    named = [BY_NAME.get(s.model.lower()) for s in profile.servos if s.model]
    if named and all(m is not None and m.protocol == 1 for m in named):
        return 1
    return 2


@DRIVERS.register(DynamixelConfig)
class DynamixelDriver(BusServoDriver):
    """Dynamixel servos through ROBOTIS's dynamixel-sdk."""

    board = "Dynamixel bus"
    needs_extra = "dynamixel"

    def __init__(self, config: DynamixelConfig, profile: Profile) -> None:
        self.sdk = require(
            "dynamixel_sdk", plugin="dynamixel driver", package="dynamixel-sdk", extra="dynamixel"
        )
        check_port(config.port)
        self.protocol = choose_protocol(config, profile)
        check_profile_models(profile, BY_NAME, "a Dynamixel", protocol=self.protocol)
        baud = config.baud or (profile.bus.baud if profile.bus else None)
        super().__init__(
            profile,
            port=config.port,
            baud=baud or FACTORY_BAUD[self.protocol],
            read_budget_ms=config.read_budget_ms,
            read_hz=config.read_hz,
            at_exit=_at_exit(config.at_exit),
            log=log,
        )
        self.config = config

    def make_bus(self) -> ServoBus:
        return DynamixelBus(
            self.sdk,
            self.port,
            self.baud,
            protocol=self.protocol,
            latency_ms=self.config.latency_ms,
        )


def _at_exit(value: str) -> AtExit:
    return "relax" if value == "relax" else "hold"
