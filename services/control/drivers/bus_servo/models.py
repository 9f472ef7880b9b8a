"""The model checks both smart servo drivers make: the profile's ``model`` names when the
driver is built, and the model numbers the servos answer with at every connect."""

from __future__ import annotations

from collections.abc import Mapping

from facesynth.runtime.profiles import Profile
from facesynth.services.control.drivers.base import DriverConfigError
from facesynth.services.control.drivers.bus_servo.bus import Ping, ServoBus
from facesynth.services.control.drivers.bus_servo.native import Model, NativePose


def check_profile_models(
    profile: Profile, known: Mapping[str, Model], vendor: str, *, protocol: int | None = None
) -> None:
    """Refuse (:class:`DriverConfigError`) a servo whose ``model`` is not in ``known`` (lower
    case names; ``vendor`` says what it is not, e.g. "a Dynamixel") or, with ``protocol``,
    one of another Dynamixel protocol than the bus runs."""
    for spec in profile.servos:
        model = known.get(spec.model.lower()) if spec.model else None
        if spec.model and model is None:
            names = ", ".join(sorted(m.name for m in known.values()))
            raise DriverConfigError(
                f"servo {spec.name!r}: model {spec.model!r} is not {vendor} the driver knows "
                f"({names})"
            )
        if protocol is not None and model is not None and model.protocol != protocol:
            raise DriverConfigError(
                f"servo {spec.name!r}: the {model.name} speaks Protocol {model.protocol}.0, "
                f"but the bus runs Protocol {protocol}.0"
            )


def check_answers(
    bus: ServoBus, pose: NativePose, answers: Mapping[int, Ping | None], *, strict: bool
) -> tuple[dict[int, Model], dict[int, str]]:
    """The model of every profile servo that answered a ping (by id), checked against the
    bus's known models and the profile's ``model``; with ``strict`` the first problem raises
    :class:`DriverConfigError`, otherwise the problems are returned by id."""
    models: dict[int, Model] = {}
    problems: dict[int, str] = {}
    for name, servo_id in sorted(pose.ids.items(), key=lambda item: item[1]):
        ping = answers.get(servo_id)
        if ping is None:
            continue
        model = bus.model(ping.model_number)
        expected = pose.specs[name].model
        problem = ""
        if model is None:
            problem = (
                f"servo {name!r} (id {servo_id}) is model number {ping.model_number}, "
                f"which the {bus.name} driver does not know"
            )
        elif expected is not None and expected.lower() != model.name.lower():
            problem = (
                f"servo {name!r} (id {servo_id}) is a {model.name} (model number "
                f"{ping.model_number}), but profile {pose.profile_name!r} expects a {expected}"
            )
        if problem and strict:
            raise DriverConfigError(problem)
        if problem:
            problems[servo_id] = problem
            continue
        assert model is not None
        models[servo_id] = model
    return models, problems
