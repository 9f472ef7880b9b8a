"""runtime.plugins: registration by decorator, lookup with clear errors, discovery of modules."""

from __future__ import annotations

import sys
import textwrap
from collections.abc import Iterator
from pathlib import Path

import pytest

from facesynth.runtime.plugins import Registry, UnknownPluginError


def test_register_get_and_names() -> None:
    registry: Registry[type] = Registry("widget")

    @registry.register("zeta")
    class Zeta:
        pass

    @registry.register("alpha")
    class Alpha:
        pass

    assert registry.get("alpha") is Alpha and registry.get("zeta") is Zeta
    assert registry.names() == ("alpha", "zeta")  # sorted, whatever the registration order
    assert "alpha" in registry and "beta" not in registry


def test_unknown_name_is_a_one_line_value_error_listing_the_names() -> None:
    registry: Registry[int] = Registry("servo driver")
    registry.register("record")(1)
    registry.register("pca9685")(2)
    with pytest.raises(UnknownPluginError) as info:
        registry.get("pca9865")
    assert isinstance(info.value, ValueError)
    assert str(info.value) == "unknown servo driver 'pca9865'; expected one of pca9685, record"


def test_unknown_name_in_an_empty_registry() -> None:
    with pytest.raises(UnknownPluginError, match=r"unknown widget 'x'; expected one of \(none\)$"):
        Registry[int]("widget").get("x")


def test_a_name_taken_by_another_plugin_is_refused() -> None:
    registry: Registry[object] = Registry("widget")
    first = object()
    registry.register("a")(first)
    registry.register("a")(first)  # the same plugin again (a module imported twice) is fine
    with pytest.raises(ValueError, match="widget 'a' is registered twice"):
        registry.register("a")(object())
    assert registry.get("a") is first


@pytest.mark.parametrize("name", ["", "two words", "tab\there", " lead"])
def test_names_without_white_space(name: str) -> None:
    with pytest.raises(ValueError, match="empty or holds white space"):
        Registry[int]("widget").register(name)(1)


def _write(root: Path, files: dict[str, str]) -> None:
    for relative, text in files.items():
        path = root / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(text), encoding="utf-8")


@pytest.fixture
def plugin_root(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """A folder on sys.path; the modules imported from it are forgotten afterwards."""
    monkeypatch.syspath_prepend(str(tmp_path))
    before = set(sys.modules)
    yield tmp_path
    for name in set(sys.modules) - before:
        del sys.modules[name]


REGISTRY_PACKAGE = {
    "widgets_pkg/__init__.py": """
        from facesynth.runtime.plugins import Registry

        WIDGETS = Registry("widget", package=__name__, group="facesynth_test.widgets")
    """,
    "widgets_pkg/round.py": """
        from widgets_pkg import WIDGETS

        @WIDGETS.register("round")
        class Round:
            pass
    """,
    "widgets_pkg/square/__init__.py": """
        from widgets_pkg import WIDGETS

        WIDGETS.register("square")(4)
    """,
}


def test_modules_of_the_package_are_found_on_the_first_lookup(plugin_root: Path) -> None:
    _write(plugin_root, REGISTRY_PACKAGE)
    from widgets_pkg import WIDGETS  # type: ignore[import-not-found]

    assert "widgets_pkg.round" not in sys.modules  # nothing imported before it is needed
    assert WIDGETS.names() == ("round", "square")  # a module and a sub-package
    assert WIDGETS.get("square") == 4
    assert WIDGETS.get("round") is sys.modules["widgets_pkg.round"].Round


def test_entry_points_of_the_group_are_loaded(plugin_root: Path) -> None:
    """A plugin in another distribution: declared by an entry point, no edit in the package."""
    _write(plugin_root, REGISTRY_PACKAGE)
    _write(
        plugin_root,
        {
            "other_widgets.py": """
                from widgets_pkg import WIDGETS

                @WIDGETS.register("star")
                def star():
                    return "*"
            """,
            "other_widgets-1.0.dist-info/METADATA": """
                Metadata-Version: 2.1
                Name: other-widgets
                Version: 1.0
            """,
            "other_widgets-1.0.dist-info/entry_points.txt": """
                [facesynth_test.widgets]
                star = other_widgets:star
            """,
        },
    )
    from widgets_pkg import WIDGETS

    assert WIDGETS.names() == ("round", "square", "star")
    assert WIDGETS.get("star")() == "*"


def test_a_broken_plugin_module_fails_every_lookup(plugin_root: Path) -> None:
    _write(plugin_root, REGISTRY_PACKAGE)
    _write(plugin_root, {"widgets_pkg/broken.py": "import no_such_module_anywhere\n"})
    from widgets_pkg import WIDGETS

    for _ in range(2):
        with pytest.raises(ModuleNotFoundError, match="no_such_module_anywhere"):
            WIDGETS.names()
