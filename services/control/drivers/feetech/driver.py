"""The ``feetech`` driver: Feetech STS and SCS servos on one bus (STS3215, SCS0009, …).

The same shape as ``dynamixel`` (:mod:`..bus_servo`): at every connect each servo of the
profile is asked its model (``bus_id``, default channel + 1; checked against ``model``),
Goal Speed and (STS) Acceleration come from ``max_speed``/``max_accel`` and the torque goes
on; each pose is one Sync Write of Goal Position, and present position, load and
temperature come back by Sync Read (STS) or READ (SCS) within ``--bus-read-ms`` of bus time
a read-back, ``--bus-read-hz`` read-backs a second. A servo whose status packets carry an
error bit (overload, overheating, voltage, overcurrent, angle sensor) is held and said once.
"""

from __future__ import annotations

import logging
from typing import Annotated

import msgspec

from facesynth.runtime.profiles import Profile
from facesynth.services.control.drivers._extras import require
from facesynth.services.control.drivers.bus_servo.bus import ServoBus
from facesynth.services.control.drivers.bus_servo.driver import BusServoDriver
from facesynth.services.control.drivers.bus_servo.models import check_profile_models
from facesynth.services.control.drivers.bus_servo.options import (
    AtExitField,
    Latency,
    ReadBudget,
    ReadRate,
)
from facesynth.services.control.drivers.feetech.bus import FeetechBus
from facesynth.services.control.drivers.feetech.models import BY_NAME
from facesynth.services.control.drivers.registry import DRIVERS
from facesynth.services.control.drivers.serial_link import PORT_HELP, check_port

log = logging.getLogger("facesynth.control.feetech")

#: The factory baud rate of STS and SCS servos.
FACTORY_BAUD = 1000000


class FeetechConfig(
    msgspec.Struct, tag="feetech", tag_field="driver", kw_only=True, forbid_unknown_fields=True
):
    """Feetech STS/SCS servos on one bus (Feetech's URT-1 or any half-duplex TTL adapter)."""

    port: Annotated[str, msgspec.Meta(description=PORT_HELP)]
    baud: (
        Annotated[
            int,
            msgspec.Meta(
                gt=0,
                description="baud rate (default: the profile's [bus] baud, else 1000000, the "
                "factory setting)",
            ),
        ]
        | None
    ) = None
    read_budget_ms: ReadBudget = 2.0
    read_hz: ReadRate | None = None
    latency_ms: Latency = 16.0
    at_exit: AtExitField = "hold"


@DRIVERS.register(FeetechConfig)
class FeetechDriver(BusServoDriver):
    """Feetech servos through Feetech's scservo_sdk."""

    board = "Feetech bus"
    needs_extra = "feetech"

    def __init__(self, config: FeetechConfig, profile: Profile) -> None:
        self.sdk = require(
            "scservo_sdk", plugin="feetech driver", package="feetech-servo-sdk", extra="feetech"
        )
        check_port(config.port)
        check_profile_models(profile, BY_NAME, "a Feetech servo")
        baud = config.baud or (profile.bus.baud if profile.bus else None)
        super().__init__(
            profile,
            port=config.port,
            baud=baud or FACTORY_BAUD,
            read_budget_ms=config.read_budget_ms,
            read_hz=config.read_hz,
            at_exit="relax" if config.at_exit == "relax" else "hold",
            log=log,
        )
        self.config = config

    def make_bus(self) -> ServoBus:
        return FeetechBus(self.sdk, self.port, self.baud, latency_ms=self.config.latency_ms)
