"""Config fields shared by the smart servo bus drivers (``dynamixel``, ``feetech``)."""

from __future__ import annotations

from typing import Annotated

import msgspec

from facesynth.services.control.drivers.bus_servo.driver import (
    AT_EXIT_HELP,
    LATENCY_HELP,
    READ_BUDGET_HELP,
    READ_HZ_HELP,
)

ReadBudget = Annotated[
    float,
    msgspec.Meta(gt=0, le=1000, description=READ_BUDGET_HELP, extra={"flag": "--bus-read-ms"}),
]
ReadRate = Annotated[
    float,
    msgspec.Meta(gt=0, le=100, description=READ_HZ_HELP, extra={"flag": "--bus-read-hz"}),
]
Latency = Annotated[
    float,
    msgspec.Meta(ge=0, le=1000, description=LATENCY_HELP, extra={"flag": "--bus-latency-ms"}),
]
AtExitField = Annotated[
    str,
    msgspec.Meta(
        pattern="^(hold|relax)$", description=AT_EXIT_HELP, extra={"flag": "--bus-at-exit"}
    ),
]
