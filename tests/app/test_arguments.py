"""facesynth.app.arguments: flags derived from option structs and plugin registries."""

from __future__ import annotations

import argparse
from typing import Annotated

import msgspec
import pytest

from facesynth.app.arguments import (
    OptionError,
    PluginFlags,
    add_flags,
    given,
    merge_struct,
    struct_flags,
)
from facesynth.runtime.plugins import Registry


class Options(msgspec.Struct, kw_only=True, forbid_unknown_fields=True):
    speed: Annotated[int, msgspec.Meta(ge=1, description="how fast")] = 2
    loud: Annotated[bool, msgspec.Meta(description="make noise")] = False
    names: list[str] = []
    label: Annotated[str, msgspec.Meta(description="a label")] | None = None
    hidden: Annotated[str, msgspec.Meta(extra={"cli": False})] = ""
    renamed: Annotated[float, msgspec.Meta(extra={"flag": "--other-name"})] = 1.0


def parse(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    add_flags(parser.add_argument_group("g"), struct_flags(Options), set())
    return parser.parse_args(argv)


def test_flags_follow_the_fields() -> None:
    flags = {flag.flag: flag for flag in struct_flags(Options)}
    assert list(flags) == ["--speed", "--loud", "--names", "--label", "--other-name"]
    assert flags["--speed"].help == "how fast"
    assert flags["--label"].help == "a label"  # described inside an Optional
    assert flags["--loud"].boolean and flags["--names"].listing


def test_only_given_flags_override() -> None:
    flags = struct_flags(Options)
    assert given(parse([]), flags) == {}
    args = parse(["--speed", "5", "--no-loud", "--names", "a, b,,c", "--other-name", "2.5"])
    assert given(args, flags) == {
        "speed": "5",
        "loud": False,
        "names": ["a", "b", "c"],
        "renamed": "2.5",
    }
    merged = merge_struct(Options, {"speed": 3, "label": "x"}, given(args, flags), "node n")
    assert merged == Options(speed=5, loud=False, names=["a", "b", "c"], label="x", renamed=2.5)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--speed", "0"], "node n: --speed: Expected `int` >= 1"),
        (["--speed", "fast"], "node n: --speed: Expected `int`, got `str`"),
        (["--other-name", "x"], "node n: --other-name: Expected `float`"),
    ],
)
def test_bad_values_are_named_by_their_flag(argv: list[str], message: str) -> None:
    with pytest.raises(OptionError) as info:
        merge_struct(Options, {}, given(parse(argv), struct_flags(Options)), "node n")
    assert str(info.value).startswith(message)


class FileConfig(
    msgspec.Struct, tag="file", tag_field="kind", kw_only=True, forbid_unknown_fields=True
):
    """Read a file."""

    path: Annotated[
        str, msgspec.Meta(description="the file", extra={"flag": "--file", "selects": True})
    ]
    loop: Annotated[bool, msgspec.Meta(description="again and again")] = False


class PortConfig(
    msgspec.Struct, tag="port", tag_field="kind", kw_only=True, forbid_unknown_fields=True
):
    """Read a port."""

    port: Annotated[str, msgspec.Meta(description="the port", extra={"selects": True})]
    baud: Annotated[int, msgspec.Meta(ge=1, description="bits per second")] = 9600
    loop: Annotated[bool, msgspec.Meta(description="again and again")] = False


class Reader:
    def __init__(self, config: msgspec.Struct) -> None:
        self.config = config


@pytest.fixture
def plugin_flags() -> PluginFlags:
    readers: Registry[Reader] = Registry("reader", tag_field="kind")
    readers.register(FileConfig)(Reader)
    readers.register(PortConfig)(Reader)
    return PluginFlags(readers, "--reader", "--reader-config")


def plugin_args(flags: PluginFlags, argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    flags.add(parser, set(), "file")
    return parser.parse_args(argv)


@pytest.mark.parametrize(
    ("base", "argv", "expected"),
    [
        ({"kind": "file", "path": "a"}, [], FileConfig(path="a")),
        ({"kind": "file", "path": "a"}, ["--loop"], FileConfig(path="a", loop=True)),
        ({"kind": "file", "path": "a"}, ["--file", "b"], FileConfig(path="b")),
        ({"kind": "file", "path": "a"}, ["--port", "/dev/x"], PortConfig(port="/dev/x")),
        (
            None,
            ["--reader", "port", "--port", "p", "--baud", "115200"],
            PortConfig(port="p", baud=115200),
        ),
        ({"kind": "port", "port": "p"}, ["--baud", "3"], PortConfig(port="p", baud=3)),
    ],
    ids=["graph", "flag", "selecting-flag", "other-plugin", "by-name", "graph-plus-flag"],
)
def test_plugin_configs_from_graph_and_flags(
    plugin_flags: PluginFlags, base: dict | None, argv: list[str], expected: msgspec.Struct
) -> None:
    assert plugin_flags.config(plugin_args(plugin_flags, argv), base) == expected


@pytest.mark.parametrize(
    ("base", "argv", "message"),
    [
        (None, ["--file", "a", "--port", "b"], "choose one reader, not --file and --port"),
        (
            None,
            ["--reader", "file", "--port", "b"],
            "choose one reader, not --reader file and --port",
        ),
        (
            {"kind": "file", "path": "a"},
            ["--baud", "3"],
            "--baud does not apply to reader file (its options: --file, --loop)",
        ),
        (None, [], "choose a reader with --reader NAME"),
        (None, ["--reader", "port"], "reader port needs --port"),
        (
            {"kind": "port", "port": "p"},
            ["--baud", "0"],
            "reader port: --baud: Expected `int` >= 1",
        ),
    ],
    ids=["two-selecting", "name-and-other-flag", "stray-flag", "none", "missing", "range"],
)
def test_plugin_flag_errors(
    plugin_flags: PluginFlags, base: dict | None, argv: list[str], message: str
) -> None:
    with pytest.raises(OptionError) as info:
        plugin_flags.config(plugin_args(plugin_flags, argv), base)
    assert str(info.value) == message or str(info.value).startswith(message)


def test_a_config_file_replaces_the_graph_table(plugin_flags: PluginFlags, tmp_path) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "reader.toml"
    path.write_text('kind = "port"\nport = "/dev/y"\nbaud = 5\n')
    args = plugin_args(plugin_flags, ["--reader-config", str(path), "--baud", "6"])
    assert plugin_flags.config(args, {"kind": "file", "path": "a"}) == PortConfig(
        port="/dev/y", baud=6
    )


def test_help_names_every_plugin_of_a_shared_flag(plugin_flags: PluginFlags) -> None:
    parser = argparse.ArgumentParser()
    plugin_flags.add(parser, set(), "file")
    text = " ".join(parser.format_help().split())
    assert "file/port: again and again" in text
    assert "reader (default file). file: Read a file; port: Read a port" in text  # no ".;"


@pytest.mark.parametrize(
    ("argv", "chosen", "given"),
    [
        ([], False, []),
        (["--loop", "--baud", "3"], False, ["--baud", "--loop"]),  # options, no plugin picked
        (["--reader", "port"], True, ["--reader"]),
        (["--reader-config", "r.toml", "--loop"], True, ["--reader-config", "--loop"]),
        (["--port", "/dev/x"], True, ["--port"]),  # a selecting flag picks its plugin
    ],
    ids=["nothing", "options-only", "selector", "config-file", "selecting-flag"],
)
def test_which_plugin_flags_the_command_line_gives(
    plugin_flags: PluginFlags, argv: list[str], chosen: bool, given: list[str]
) -> None:
    args = plugin_args(plugin_flags, argv)
    assert plugin_flags.chosen(args) is chosen
    assert plugin_flags.given(args) == given
