"""The model checks both smart servo drivers share (bus_servo/models.py): the profile's model
names when a driver is built, and the model numbers the servos answer with at connect."""

from __future__ import annotations

from typing import Any

import dynamixel_sdk
import msgspec
import pytest

from facesynth.runtime.profiles import Profile, load_profile
from facesynth.services.control.drivers.base import DriverConfigError
from facesynth.services.control.drivers.bus_servo.bus import Ping
from facesynth.services.control.drivers.bus_servo.models import check_answers
from facesynth.services.control.drivers.bus_servo.native import NativePose
from facesynth.services.control.drivers.dynamixel.bus import DynamixelBus
from facesynth.services.control.drivers.registry import DRIVERS

PAPER16 = load_profile("paper16")


def with_models(*models: str) -> Profile:
    """paper16 with the first servos' ``model`` set to ``models``."""
    servos = list(PAPER16.servos)
    for i, model in enumerate(models):
        servos[i] = msgspec.structs.replace(servos[i], model=model)
    return msgspec.structs.replace(PAPER16, servos=servos)


def build(config: dict[str, Any], profile: Profile) -> Any:
    return DRIVERS.build(DRIVERS.parse({**config, "port": "/dev/null"}), profile)


@pytest.mark.parametrize(
    ("config", "models", "message"),
    [
        (
            {"driver": "dynamixel"},
            ("XL430-W250", "XL999"),
            "servo 'left_eyebrow': model 'XL999' is not a Dynamixel the driver knows "
            "(AX-12A, AX-12W, AX-18A, MX-106",
        ),
        (
            {"driver": "dynamixel", "protocol": 2},
            ("AX-12A",),
            "the AX-12A speaks Protocol 1.0, but the bus runs Protocol 2.0",
        ),
        (
            {"driver": "feetech"},
            ("STS3032",),
            "model 'STS3032' is not a Feetech servo the driver knows (SCS0009, STS3095, "
            "STS3215, STS3250)",
        ),
    ],
)
def test_a_profile_naming_a_model_the_driver_cannot_serve_is_refused(
    config: dict[str, Any], models: tuple[str, ...], message: str
) -> None:
    profile = with_models(*models)
    with pytest.raises(DriverConfigError) as refused:
        build(config, profile)
    assert message in str(refused.value)


def test_known_models_of_the_buss_protocol_are_taken() -> None:
    assert build({"driver": "dynamixel"}, with_models("xl430-w250", "XM430-W350"))
    assert build({"driver": "dynamixel"}, with_models("AX-12A")).protocol == 1
    assert build({"driver": "feetech"}, with_models("STS3215", "scs0009"))


def test_answers_are_checked_against_the_bus_and_the_profile() -> None:
    bus = DynamixelBus(dynamixel_sdk, "/dev/null", 1000000, protocol=2, latency_ms=0)
    pose = NativePose(with_models("XM430-W350"))
    answers = {1: Ping(1060), 2: Ping(9999), 3: None, **{i: Ping(1060) for i in range(4, 17)}}
    models, problems = check_answers(bus, pose, answers, strict=False)
    assert set(models) == set(range(4, 17)) and models[4].name == "XL430-W250"
    assert problems == {
        1: "servo 'right_eyebrow' (id 1) is a XL430-W250 (model number 1060), but "
        "profile 'paper16' expects a XM430-W350",
        2: "servo 'left_eyebrow' (id 2) is model number 9999, which the Dynamixel "
        "Protocol 2.0 driver does not know",
    }
    with pytest.raises(DriverConfigError, match=r"\(id 1\) is a XL430-W250"):
        check_answers(bus, pose, answers, strict=True)
