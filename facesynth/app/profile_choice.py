"""Which profile a robot's nodes use when none is named, and whether its driver can show it.

A control node without ``profile`` takes the profile its driver expects
(:attr:`~services.control.drivers.base.ServoDriver.expected_profile`: ``vmc`` → ``arkit52``,
``virtual`` → ``virtual``), said in one log line, else :data:`DEFAULT_PROFILE`. A translator
without one follows the control node of its robot (the same ``robot``), else the default too.
A profile with controls its driver cannot show is refused with the profiles it can show.

:func:`settle` is where a chain's setup is settled, once, before any node is built: the
profiles (each file read once), F's neutral window and the drivers, handed to every node in a
:class:`~facesynth.app.stages.setup.Setup`.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from typing import Any

from facesynth.app.graph import Graph, plugin_config
from facesynth.app.nodes import DEFAULT_PROFILE, ControlNode, TranslatorNode
from facesynth.app.stages.driver_fit import (
    ProfileFitError,
    check_fit,
    driver_class,
    driver_name,
    fitting_profiles,
)
from facesynth.app.stages.setup import Setup
from facesynth.runtime.profiles import ProfileError

__all__ = [
    "DEFAULT_PROFILE",
    "ProfileFitError",
    "check_fit",
    "driver_class",
    "driver_name",
    "fitting_profiles",
    "settle",
    "settle_profiles",
]

log = logging.getLogger("facesynth")


def settle(
    graph: Graph,
    configs: Mapping[str, Any] | None = None,
    *,
    check: bool = True,
    fill: bool = True,
    plugins: bool = True,
) -> Setup:
    """The setup of ``graph``'s nodes, settled once, in one place: each robot's profile (see
    :func:`settle_profiles`; unless ``fill`` is false, a node naming none keeps the default),
    each profile file read once and shared by the nodes that use it, F's neutral window (the
    first translator's profile's), each node's plugin config (``configs``, else its own table
    validated, unless ``plugins`` is false) and whether the chain's input is ``--fast``.
    """
    configs = dict(configs or {})
    if fill:
        settle_profiles(graph, configs, check=False)
    setup = Setup(fast=any(getattr(node, "fast", False) for node in graph.sources().values()))
    for name, node in graph.nodes.items():
        config = configs.get(name)
        if config is None and plugins:
            config = plugin_config(node, f"node {name}")
        if config is not None:
            setup.configs[name] = config
        if isinstance(node, TranslatorNode) and setup.neutral_profile is None:
            setup.neutral_profile = node.profile or DEFAULT_PROFILE
    if check:
        for name, node in graph.nodes.items():  # refused before anything starts
            if isinstance(node, ControlNode) and node.profile is not None:
                try:
                    profile = setup.loaded(node.profile)
                except ProfileError:
                    continue  # said by the builder, with every problem
                check_fit(configs.get(name) or node.driver, profile)
    return setup


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
    if check:
        settle(graph, configs, fill=False, plugins=False)
    return graph
