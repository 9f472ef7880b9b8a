"""facesynth.runtime.plugins: registration, discovery, configs from mappings and files."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import msgspec
import pytest

from facesynth.runtime.plugins import PluginError, Registry


class Widget:
    """A thing built from a config."""

    def __init__(self, config: msgspec.Struct, *extra: object) -> None:
        self.config = config
        self.extra = extra


class SpinConfig(
    msgspec.Struct, tag="spin", tag_field="kind", kw_only=True, forbid_unknown_fields=True
):
    """Spin a widget."""

    speed: Annotated[int, msgspec.Meta(ge=1)] = 3
    name: str


class StopConfig(
    msgspec.Struct, tag="stop", tag_field="kind", kw_only=True, forbid_unknown_fields=True
):
    """Stop a widget."""


@pytest.fixture
def registry() -> Registry[Widget]:
    widgets: Registry[Widget] = Registry("widget", tag_field="kind")
    widgets.register(SpinConfig)(Widget)

    @widgets.register(StopConfig)
    class Stopper(Widget):
        """Stops things. More text here."""

    return widgets


def test_registered_plugins_are_named_by_their_tag(registry: Registry[Widget]) -> None:
    assert registry.names() == ["spin", "stop"]
    assert "spin" in registry and "fly" not in registry
    assert registry.get("stop").summary == "Stops things. More text here."
    assert registry.get("spin").summary == "A thing built from a config."
    assert [field.name for field in registry.get("spin").fields()] == ["speed", "name"]


def test_parse_build_and_round_trip(registry: Registry[Widget]) -> None:
    config = registry.parse({"kind": "spin", "name": "x", "speed": "7"})  # strings convert
    assert config == SpinConfig(name="x", speed=7)
    widget = registry.build(config, "profile")
    assert isinstance(widget, Widget) and widget.config is config and widget.extra == ("profile",)
    assert registry.to_builtins(config) == {"kind": "spin", "speed": 7, "name": "x"}
    assert registry.parse(registry.to_builtins(config)) == config


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"kind": "fly"}, "g.toml: unknown widget 'fly' (known: spin, stop)"),
        ({}, "g.toml: a widget needs kind = NAME (known: spin, stop)"),
        ({"kind": 4}, "g.toml: a widget needs kind = NAME"),
        ({"kind": "spin"}, "g.toml: widget spin: Object missing required field `name`"),
        ({"kind": "spin", "name": "x", "speed": 0}, "Expected `int` >= 1 - at `$.speed`"),
        ({"kind": "spin", "name": "x", "wings": 2}, "Object contains unknown field `wings`"),
        ({"kind": "spin", "name": "x", "speed": "fast"}, "Expected `int`, got `str`"),
    ],
    ids=["unknown", "no-tag", "tag-not-a-string", "missing", "range", "unknown-field", "type"],
)
def test_bad_configs_give_one_line(registry: Registry[Widget], data: dict, message: str) -> None:
    with pytest.raises(PluginError) as info:
        registry.parse(data, "g.toml")
    assert message in str(info.value)
    assert "\n" not in str(info.value)


def test_a_config_of_another_plugin_is_refused(registry: Registry[Widget]) -> None:
    registry.unregister("stop")

    @registry.register(StopConfig)
    class Other(Widget):
        pass

    class Fake(msgspec.Struct, tag="stop", tag_field="kind"):
        pass

    with pytest.raises(PluginError, match="is not the config of widget 'stop'"):
        registry.build(Fake())


def test_register_needs_a_config_tagged_for_this_registry(registry: Registry[Widget]) -> None:
    class Untagged(msgspec.Struct):
        pass

    class OtherField(msgspec.Struct, tag="x", tag_field="type"):
        pass

    for config in (Untagged, OtherField):
        with pytest.raises(TypeError, match="tag_field='kind'"):
            registry.register(config)


@pytest.mark.parametrize(
    ("name", "content", "expected"),
    [
        ("w.toml", b'kind = "spin"\nname = "a"\n', SpinConfig(name="a")),
        ("w.json", b'{"kind": "stop"}', StopConfig()),
    ],
)
def test_load_from_files(
    registry: Registry[Widget], tmp_path: Path, name: str, content: bytes, expected: object
) -> None:
    (tmp_path / name).write_bytes(content)
    assert registry.load(tmp_path / name) == expected


@pytest.mark.parametrize(
    ("name", "content", "message"),
    [
        ("w.toml", b'kind = "spin\n', "not valid TOML"),
        ("w.json", b"{", "not valid JSON"),
        ("w.json", b"[1]", "expected a table of settings"),
        ("w.toml", b'kind = "caf\xe9"', "cannot read widget config"),
        ("w.toml", b'kind = "fly"\n', "unknown widget 'fly'"),
    ],
)
def test_load_bad_files(
    registry: Registry[Widget], tmp_path: Path, name: str, content: bytes, message: str
) -> None:
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(PluginError) as info:
        registry.load(path)
    assert message in str(info.value) and str(path) in str(info.value)


def test_missing_file(registry: Registry[Widget], tmp_path: Path) -> None:
    with pytest.raises(PluginError, match=r"cannot read widget config .*gone.toml"):
        registry.load(tmp_path / "gone.toml")


def test_discovery_imports_every_module_of_the_package() -> None:
    from facesynth.services.control.drivers.registry import DRIVERS
    from facesynth.services.points.backends.registry import BACKENDS
    from facesynth.services.sensor.sources.registry import SOURCES

    assert "record" in DRIVERS.names()
    assert {"tracker", "openface", "track"} <= set(BACKENDS.names())
    assert {"video", "camera", "images", "ticks"} <= set(SOURCES.names())
