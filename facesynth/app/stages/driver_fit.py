"""Whether a control node's driver can show its profile's controls (a ``vmc`` avatar cannot move
``paper16``'s servos): checked once at start, refused with the profiles it can show."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import msgspec

from facesynth.runtime.profiles import Profile, ProfileError, available_profiles, load_profile
from facesynth.services.control.drivers.base import ServoDriver
from facesynth.services.control.drivers.registry import DRIVERS

Driver = Mapping[str, Any] | msgspec.Struct


class ProfileFitError(ValueError):
    """A profile whose controls the chosen driver cannot show; one line."""


def driver_name(driver: Driver) -> str | None:
    """The name of the driver of a config or of a graph's driver table."""
    if isinstance(driver, msgspec.Struct):
        name = driver.__struct_config__.tag
    else:
        name = driver.get(DRIVERS.tag_field)
    return name if isinstance(name, str) else None


def driver_class(driver: Driver) -> type[ServoDriver] | None:
    """The registered class of a driver config or table, or None (unknown, or not a class)."""
    name = driver_name(driver)
    if name is None or name not in DRIVERS:
        return None
    factory = DRIVERS.get(name).factory
    return factory if isinstance(factory, type) and issubclass(factory, ServoDriver) else None


def check_fit(driver: Driver, profile: Profile) -> None:
    """Refuse ``profile`` when ``driver`` (a config or a graph's driver table) cannot show some
    of its controls, naming the profiles it can show (:class:`ProfileFitError`)."""
    cls = driver_class(driver)
    if cls is None:
        return
    unshown = cls.unshown_controls(spec.name for spec in profile.servos)
    if not unshown:
        return
    listed = ", ".join(unshown[:4]) + (", …" if len(unshown) > 4 else "")
    fitting = " or ".join(fitting_profiles(cls)) or "a profile of those controls"
    raise ProfileFitError(
        f"the {driver_name(driver)} driver cannot show {len(unshown)} of the "
        f"{len(profile.servos)} controls of profile {profile.name} ({listed}); it shows "
        f"{cls.shown_controls_described}: choose --profile {fitting}"
    )


def fitting_profiles(cls: type[ServoDriver]) -> list[str]:
    """The profiles found (shipped and the user's) whose every control ``cls`` can show."""
    names = []
    for name in available_profiles():
        try:
            profile = load_profile(name)
        except ProfileError:  # a broken user profile is no candidate
            continue
        if not cls.unshown_controls(spec.name for spec in profile.servos):
            names.append(name)
    return names
