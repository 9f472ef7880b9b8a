"""Which profile a robot's nodes use when none is named, and whether its driver can show it.

A control node without ``profile`` takes the profile its driver expects
(:attr:`~services.control.drivers.base.ServoDriver.expected_profile`: ``vmc`` → ``arkit52``,
``virtual`` → ``virtual``), said in one log line, else :data:`DEFAULT_PROFILE`. A translator
without one follows the control node of its robot (the same ``robot``), else the default too.
A profile with controls its driver cannot show is refused with the profiles it can show.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from typing import Any

import msgspec

from facesynth.app.graph import Graph
from facesynth.app.nodes import DEFAULT_PROFILE, ControlNode, TranslatorNode
from facesynth.runtime.profiles import Profile, ProfileError, available_profiles, load_profile
from facesynth.services.control.drivers.base import ServoDriver
from facesynth.services.control.drivers.registry import DRIVERS

__all__ = ["DEFAULT_PROFILE", "ProfileFitError", "check_fit", "settle_profiles"]

log = logging.getLogger("facesynth")

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


def settle_profiles(
    graph: Graph, configs: Mapping[str, Any] | None = None, *, check: bool = True
) -> Graph:
    """Fill in the profile of every control and translator node that names none (in place),
    then (unless ``check`` is false) refuse a control node whose driver cannot show its
    profile (:func:`check_fit`).

    ``configs`` are the nodes' validated plugin configs when the command line changed them
    (its ``--driver``); else each control node's own driver table is read.
    """
    configs = configs or {}
    chosen: dict[str | None, str] = {}  # robot -> its control node's profile
    for name, node in graph.nodes.items():
        if not isinstance(node, ControlNode):
            continue
        driver = configs.get(name) or node.driver
        if node.profile is None:
            cls = driver_class(driver)
            expected = cls.expected_profile if cls is not None else None
            if expected is not None:
                log.info(
                    "control node %s: no profile given; the %s driver expects %s, using it "
                    "(choose another with --profile)",
                    name,
                    driver_name(driver),
                    expected,
                )
            node.profile = expected or DEFAULT_PROFILE
        chosen.setdefault(node.robot, node.profile)
    for node in graph.nodes.values():
        if isinstance(node, TranslatorNode) and node.profile is None:
            node.profile = chosen.get(node.robot, DEFAULT_PROFILE)
    for name, node in graph.nodes.items():  # refused before anything starts
        if check and isinstance(node, ControlNode) and node.profile is not None:
            try:
                profile = load_profile(node.profile)
            except ProfileError:
                continue  # said by the builder, with every problem
            check_fit(configs.get(name) or node.driver, profile)
    return graph


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
