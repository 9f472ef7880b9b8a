"""Command-line options derived from msgspec structs: a node's options, a plugin's config.

Every field of an options struct becomes ``--field-name`` (or the flag its
``Meta(extra={"flag": ...})`` names), with the field's ``Meta(description=...)`` as help.
Values are parsed by msgspec (``strict=False``: ``"115200"`` becomes an int), so one
validation serves the graph file and the command line; booleans take ``--x/--no-x``, lists are
comma-separated. A flag given on the command line overrides the same field of a graph node.

Several structs may share a flag (``--profile`` of the translator and of the control
interface): the flag is declared once and applies to each of them.
"""

from __future__ import annotations

import argparse
import functools
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace
from typing import Any

import msgspec

from facesynth.runtime.plugins import Plugin, Registry


class OptionError(ValueError):
    """Options (or a graph's nodes) that do not fit together, or do not fit the chosen plugin:
    the one error every command reports as ``facesynth CMD: error: …``."""


@dataclass(frozen=True)
class Flag:
    """One command-line flag for one struct field."""

    flag: str
    field: str
    help: str
    boolean: bool
    listing: bool
    selects: bool

    @property
    def dest(self) -> str:
        """The argparse destination shared by every field with this flag."""
        return flag_dest(self.flag)


def flag_dest(flag: str) -> str:
    """The argparse destination of ``--some-flag``."""
    return "opt_" + flag.lstrip("-").replace("-", "_")


def _annotated(
    field_type: msgspec.inspect.Type,
) -> tuple[msgspec.inspect.Type, str, dict[str, Any]]:
    """The field's base type, description and extra metadata (Meta on it or on an Optional)."""
    if isinstance(field_type, msgspec.inspect.UnionType):  # `X | None`: look inside X
        inner = [t for t in field_type.types if not isinstance(t, msgspec.inspect.NoneType)]
        if len(inner) == 1:
            return _annotated(inner[0])
    if isinstance(field_type, msgspec.inspect.Metadata):
        description = (field_type.extra_json_schema or {}).get("description", "")
        return field_type.type, description, dict(field_type.extra or {})
    return field_type, "", {}


def struct_flags(struct: type[msgspec.Struct], skip: Iterable[str] = ()) -> list[Flag]:
    """The flags of a struct's fields (the tag and ``skip`` left out)."""
    return list(_struct_flags(struct, frozenset(skip)))


@functools.cache
def _struct_flags(struct: type[msgspec.Struct], skip: frozenset[str]) -> tuple[Flag, ...]:
    # Cached: msgspec.inspect evaluates every annotation each time (about 1 ms a struct), and
    # building the parser asks for the same plugin structs some 2,700 times.
    info = msgspec.inspect.type_info(struct)
    assert isinstance(info, msgspec.inspect.StructType)
    flags = []
    for field in info.fields:
        if field.name in skip:
            continue
        base, description, extra = _annotated(field.type)
        if extra.get("cli") is False:
            continue
        flags.append(
            Flag(
                flag=extra.get("flag", "--" + field.name.replace("_", "-")),
                field=field.name,
                help=description,
                boolean=isinstance(base, msgspec.inspect.BoolType),
                listing=isinstance(base, msgspec.inspect.ListType),
                selects=bool(extra.get("selects", False)),
            )
        )
    return tuple(flags)


def add_flags(group: argparse._ArgumentGroup, flags: Iterable[Flag], seen: set[str]) -> None:
    """Declare each flag once (defaults suppressed, so only given flags reach the namespace)."""
    for flag in flags:
        if flag.flag in seen:
            continue
        seen.add(flag.flag)
        metavar = None if flag.boolean else flag.field.upper()
        group.add_argument(
            flag.flag,
            dest=flag.dest,
            default=argparse.SUPPRESS,
            action=argparse.BooleanOptionalAction if flag.boolean else "store",
            metavar=metavar,
            help=flag.help or None,
        )


def given(args: argparse.Namespace, flags: Iterable[Flag]) -> dict[str, Any]:
    """``{field: value}`` of the flags given on the command line."""
    values: dict[str, Any] = {}
    for flag in flags:
        if hasattr(args, flag.dest):
            value = getattr(args, flag.dest)
            if flag.listing and isinstance(value, str):
                value = [part.strip() for part in value.split(",") if part.strip()]
            values[flag.field] = value
    return values


def explain(what: str, error: msgspec.ValidationError, flags: Iterable[Flag]) -> str:
    """A msgspec validation message in the command line's words, about ``what``.

    ``Object missing required field `out``` becomes ``WHAT needs --out``; ``… - at `$.threads```
    becomes ``WHAT: --threads: …``.
    """
    by_field = {flag.field: flag.flag for flag in flags}
    text = str(error)
    missing = re.fullmatch(r"Object missing required field `(\w+)`", text)
    if missing and missing.group(1) in by_field:
        return f"{what} needs {by_field[missing.group(1)]}"
    located = re.fullmatch(r"(.*) - at `\$\.(\w+)`", text)
    if located and located.group(2) in by_field:
        return f"{what}: {by_field[located.group(2)]}: {located.group(1)}"
    return f"{what}: {text}"


def merge_struct(
    struct: type[msgspec.Struct], base: Mapping[str, Any], overrides: Mapping[str, Any], what: str
) -> msgspec.Struct:
    """``base`` (a graph node's fields) updated with command-line ``overrides``, validated."""
    try:
        return msgspec.convert({**base, **overrides}, struct, strict=False)
    except msgspec.ValidationError as exc:
        raise OptionError(explain(what, exc, struct_flags(struct))) from None


class PluginFlags:
    """The command-line face of a plugin registry: ``--driver NAME``, a config file, field flags.

    ``selector`` picks the plugin (``--driver``); ``config_file`` (``--driver-config FILE``)
    loads a whole config; each plugin's fields become flags, and a field marked
    ``Meta(extra={"selects": True})`` (``--openface-csv FILE``) also picks its plugin.
    """

    def __init__(
        self, registry: Registry[Any], selector: str, config_file: str | None = None
    ) -> None:
        self.registry = registry
        self.selector = selector
        self.config_file = config_file

    def _plugin_flags(self, plugin: Plugin[Any]) -> list[Flag]:
        return struct_flags(plugin.config)

    def flags(self) -> list[Flag]:
        """Every plugin's field flags."""
        return [flag for plugin in self.registry for flag in self._plugin_flags(plugin)]

    def add(
        self,
        parser: argparse.ArgumentParser,
        seen: set[str],
        default: str | None,
        purpose: str | None = None,
    ) -> None:
        """Declare ``--NAME``, ``--NAME-config`` and every plugin's field flags; ``purpose``:
        what the group is for, under its title in ``--help`` (a command that takes them for
        one use only)."""
        kind = self.registry.kind
        group = parser.add_argument_group(
            f"{kind} ({', '.join(self.registry.names())})", description=purpose
        )
        summaries = "; ".join(f"{p.name}: {p.summary.rstrip('.')}" for p in self.registry)
        group.add_argument(
            self.selector,
            dest=f"plugin_{kind}",
            default=argparse.SUPPRESS,
            choices=self.registry.names(),
            metavar="NAME",
            help=f"{kind}{f' (default {default})' if default else ''}. {summaries}",
        )
        if self.config_file:
            group.add_argument(
                self.config_file,
                dest=f"plugin_{kind}_file",
                default=argparse.SUPPRESS,
                metavar="FILE",
                help=f"{kind} settings from a TOML or JSON file ({self.registry.tag_field} = NAME, "
                "then its fields); options above override it",
            )
        for plugin in self.registry:
            flags = [f for f in self._plugin_flags(plugin) if f.flag not in seen]
            for flag in flags:  # one help line per flag, naming every plugin that has it
                owners = [
                    p.name
                    for p in self.registry
                    if any(f.flag == flag.flag for f in self._plugin_flags(p))
                ]
                prefix = f"{'/'.join(owners)}: "
                text = flag.help.removeprefix(prefix) if flag.help else ""  # not said twice
                add_flags(group, [replace(flag, help=prefix + text if text else "")], seen)

    def chosen(self, args: argparse.Namespace) -> bool:
        """Whether the command line picks a plugin: the selector (``--driver NAME``), the config
        file or a field flag that selects one (``--camera``)."""
        kind = self.registry.kind
        return (
            hasattr(args, f"plugin_{kind}")
            or hasattr(args, f"plugin_{kind}_file")
            or any(hasattr(args, flag.dest) for flag in self.flags() if flag.selects)
        )

    def given(self, args: argparse.Namespace) -> list[str]:
        """The registry's flags the command line gives: the selector, the config file, then
        the field flags (sorted)."""
        kind = self.registry.kind
        flags = [self.selector] if hasattr(args, f"plugin_{kind}") else []
        if self.config_file and hasattr(args, f"plugin_{kind}_file"):
            flags.append(self.config_file)
        return flags + sorted({f.flag for f in self.flags() if hasattr(args, f.dest)})

    def config(self, args: argparse.Namespace, base: Mapping[str, Any] | None) -> msgspec.Struct:
        """The plugin config: ``base`` (from a graph) with the command line applied, validated."""
        kind, tag = self.registry.kind, self.registry.tag_field
        data: dict[str, Any] = dict(base or {})
        if hasattr(args, f"plugin_{kind}_file"):
            data = self.registry.to_builtins(
                self.registry.load(getattr(args, f"plugin_{kind}_file"))
            )
        chosen = getattr(args, f"plugin_{kind}", None)
        selecting = {
            plugin.name: [f.flag for f in self._plugin_flags(plugin) if f.selects]
            for plugin in self.registry
        }
        picked = {
            name: given_flags
            for name, flags in selecting.items()
            if (given_flags := [flag for flag in flags if hasattr(args, flag_dest(flag))])
        }
        if len(picked) > 1 or (picked and chosen is not None and chosen not in picked):
            named = [flag for flags in picked.values() for flag in flags]
            if chosen is not None and chosen not in picked:
                named.insert(0, f"{self.selector} {chosen}")
            raise OptionError(f"choose one {kind}, not {' and '.join(named)}")
        if picked:
            chosen = next(iter(picked))
        if chosen is not None and chosen != data.get(tag):
            data = {tag: chosen}
        name = data.get(tag)
        if not isinstance(name, str):
            raise OptionError(f"choose a {kind} with {self.selector} NAME")
        plugin = self.registry.get(name)
        own = self._plugin_flags(plugin)
        own_flags = {f.flag for f in own}
        stray = sorted(
            {f.flag for f in self.flags() if hasattr(args, f.dest) and f.flag not in own_flags}
        )
        if stray:
            options = ", ".join(f.flag for f in own) or "none"
            raise OptionError(
                f"{', '.join(stray)} does not apply to {kind} {name} (its options: {options})"
            )
        data.update(given(args, own))
        try:
            return msgspec.convert(data, plugin.config, strict=False)
        except msgspec.ValidationError as exc:
            raise OptionError(explain(f"{kind} {name}", exc, own)) from None
