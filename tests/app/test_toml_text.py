"""facesynth.app.toml_text: one TOML value, as the graph and profile writers use it."""

from __future__ import annotations

import tomllib

import pytest

from facesynth.app.toml_text import toml_value


def test_values_read_back_as_written() -> None:
    value = {"a b": [1, 2.5, 'x"y'], "on": True, "t": {"k": -3}}
    assert tomllib.loads(f"v = {toml_value(value)}")["v"] == value
    assert toml_value(value) == '{ "a b" = [1, 2.5, "x\\"y"], "on" = true, "t" = { "k" = -3 } }'


def test_a_graphs_tables_have_bare_keys_and_leave_out_none() -> None:
    value = {"model": "fast", "gain": None, "mix": [{"jaw": 1.0, "lip": None}]}
    text = toml_value(value, bare_keys=True, skip_none=True)
    assert text == '{ model = "fast", mix = [{ jaw = 1.0 }] }'


@pytest.mark.parametrize("value", [None, {"k": None}, [None], (1, 2), b"x"])
def test_what_toml_cannot_hold_is_refused(value: object) -> None:
    with pytest.raises(TypeError, match="as TOML"):
        toml_value(value)
