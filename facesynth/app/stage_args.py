"""The command-line options of the five stages, read from their node structs and registries.

``facesynth sensor|points|features|translator|control`` take their own stage's options, and
``facesynth run`` takes every stage's (a flag applies to every node that has the field). With
``--graph FILE`` a flag overrides the node's value from the file; without, it overrides the
node's defaults.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterable
from typing import Any

import msgspec

from facesynth.app.arguments import PluginFlags, add_flags, given, merge_struct, struct_flags
from facesynth.app.nodes import PLUGIN_FIELDS, stage_of
from facesynth.app.stages.registry import STAGES

#: How each plugin is chosen on the command line, and the plugin a bare stage uses (read from
#: each stage's plugin table).
PLUGIN_FLAGS: dict[str, tuple[PluginFlags, str]] = {
    stage.name: (
        PluginFlags(stage.plugin.registry, stage.plugin.flag, stage.plugin.config_flag),
        stage.plugin.default,
    )
    for stage in STAGES
    if stage.plugin is not None
}


def node_flags(stage: str) -> list[Any]:
    """The flags of a stage's own options (its plugin's come from the registry)."""
    return struct_flags(STAGES.get(stage).node, skip=PLUGIN_FIELDS)


def add_stage_arguments(parser: argparse.ArgumentParser, stages: Iterable[str]) -> None:
    """Declare the options of ``stages`` (a flag shared by several is declared once)."""
    seen: set[str] = set()
    for stage in stages:
        doc = (STAGES.get(stage).node.__doc__ or stage).strip().splitlines()[0].replace("``", "")
        group = parser.add_argument_group(f"{stage} node: {doc}")
        add_flags(group, node_flags(stage), seen)
        if stage in PLUGIN_FLAGS:
            flags, default = PLUGIN_FLAGS[stage]
            flags.add(parser, seen, default)


def apply_arguments(name: str, node: Any, args: argparse.Namespace) -> tuple[Any, Any]:
    """``node`` with the command line's flags applied, and its validated plugin config.

    The node's plugin table is replaced by the validated config, so the node describes what
    runs (for ``facesynth compose`` and logs).
    """
    stage = stage_of(node)
    data = msgspec.to_builtins(node)
    overrides = given(args, node_flags(stage))
    config = None
    if stage in PLUGIN_FLAGS:
        flags, _ = PLUGIN_FLAGS[stage]
        table = STAGES.get(stage).plugin
        assert table is not None
        field = table.field
        config = flags.config(args, data.get(field))
        overrides[field] = flags.registry.to_builtins(config)
    return merge_struct(type(node), data, overrides, f"{stage} node {name}"), config
