"""runtime.field_types: a struct object's fields are checked for their declared types exactly as
decoding the object's bytes checks them (same verdict, same msgspec text), nested structs and
constraints included; the check is built once per class."""

from __future__ import annotations

from typing import Annotated, Any, Literal

import msgspec
import numpy as np
import pytest

from facesynth.runtime.field_types import FieldTypes


class Inner(msgspec.Struct, frozen=True):
    name: str
    values: list[float] = []


class Other(msgspec.Struct, frozen=True):
    name: str


class Outer(msgspec.Struct, tag="outer", frozen=True, kw_only=True):
    count: Annotated[int, msgspec.Meta(ge=0, le=10)]
    ratio: float = 0.0
    label: Annotated[str, msgspec.Meta(max_length=4)] = ""
    kind: Literal["a", "b"] = "a"
    maybe: float | None = None
    pair: tuple[int, str] = (0, "")
    flags: dict[str, bool] = {}
    inner: Inner | None = None
    inners: list[Inner] = []
    by_name: dict[str, Inner] = {}
    fixed: tuple[Inner, int] | None = None
    either: Inner | str = ""
    data: bytes = b""


OUTER = FieldTypes(Outer)
INNER = Inner(name="i", values=[1.0, 2.0])


def _decoded_error(obj: msgspec.Struct) -> str | None:
    """What msgspec says decoding ``obj``'s bytes (``None``: they decode)."""
    try:
        msgspec.msgpack.decode(msgspec.msgpack.encode(obj), type=type(obj))
    except msgspec.ValidationError as exc:
        return str(exc)
    return None


def _checked_error(obj: msgspec.Struct) -> str | None:
    try:
        OUTER.check(obj)
    except msgspec.ValidationError as exc:
        return str(exc)
    return None


VALID = [
    Outer(count=0),
    Outer(
        count=10,
        ratio=2,  # an int is a float, as on the wire
        label="abcd",
        kind="b",
        maybe=1.5,
        pair=(1, "x"),
        flags={"on": True},
        inner=INNER,
        inners=[INNER, Inner(name="j")],
        by_name={"k": INNER},
        fixed=(INNER, 3),
        either=INNER,
        data=b"\x00\xff",
    ),
    Outer(count=1, either="text", pair=[2, "y"]),  # type: ignore[arg-type]  # a list for a tuple
]


@pytest.mark.parametrize("obj", VALID, ids=["defaults", "every field", "str arm"])
def test_a_well_typed_object_passes(obj: Outer) -> None:
    assert _decoded_error(obj) is None
    OUTER.check(obj)


WRONG: list[tuple[str, dict[str, Any], str]] = [
    ("str for int", {"count": "1"}, "Expected `int`, got `str` - at `$.count`"),
    ("bool for int", {"count": True}, "Expected `int`, got `bool` - at `$.count`"),
    ("float for int", {"count": 1.0}, "Expected `int`, got `float` - at `$.count`"),
    ("Meta ge", {"count": -1}, "Expected `int` >= 0 - at `$.count`"),
    ("Meta le", {"count": 11}, "Expected `int` <= 10 - at `$.count`"),
    ("Meta max_length", {"label": "abcde"}, "Expected `str` of length <= 4 - at `$.label`"),
    ("Literal", {"kind": "c"}, "Invalid enum value 'c' - at `$.kind`"),
    ("bool for float", {"ratio": False}, "Expected `float`, got `bool` - at `$.ratio`"),
    ("str for optional", {"maybe": "1"}, "Expected `float | null`, got `str` - at `$.maybe`"),
    ("tuple item", {"pair": (1, 2)}, "Expected `str`, got `int` - at `$.pair[1]`"),
    ("tuple length", {"pair": (1,)}, "Expected `array` of length 2, got 1 - at `$.pair`"),
    ("table value", {"flags": {"on": 1}}, "Expected `bool`, got `int` - at `$.flags[...]`"),
    ("table key", {"flags": {1: True}}, "Expected `str`, got `int` - at `key` in `$.flags`"),
    ("nested field", {"inner": Inner(name=3)}, "Expected `str`, got `int` - at `$.inner.name`"),  # type: ignore[arg-type]
    (
        "nested list item",
        {"inners": [INNER, Inner(name="x", values=[1.0, "2"])]},  # type: ignore[list-item]
        "Expected `float`, got `str` - at `$.inners[1].values[1]`",
    ),
    ("str for list", {"inners": "x"}, "Expected `array`, got `str` - at `$.inners`"),
    ("str for bytes", {"data": "x"}, "Expected `bytes`, got `str` - at `$.data`"),
    (
        "other struct",
        {"inner": Other(name="o")},
        "Expected `Inner`, got `Other` - at `$.inner`",
    ),
    (
        "mapping for nested",
        {"inners": [{"name": "x", "values": []}]},
        "Expected `Inner`, got `dict` - at `$.inners[0]`",
    ),
    (
        "mapping in a table",
        {"by_name": {"k": {"name": "x"}}},
        "Expected `Inner`, got `dict` - at `$.by_name[...]`",
    ),
    (
        "mapping in a tuple",
        {"fixed": ({"name": "x"}, 1)},
        "Expected `Inner`, got `dict` - at `$.fixed[0]`",
    ),
    (
        "mapping for a union's struct",
        {"either": {"name": "x"}},
        "Expected `Inner`, got `dict` - at `$.either`",
    ),
    (
        "incomplete mapping",
        {"inners": [{"values": []}]},
        "Object missing required field `name` - at `$.inners[0]`",
    ),
]


@pytest.mark.parametrize(("fields", "reason"), [w[1:] for w in WRONG], ids=[w[0] for w in WRONG])
def test_a_wrong_typed_field_is_refused_as_its_bytes_are(
    fields: dict[str, Any], reason: str
) -> None:
    obj = msgspec.structs.replace(Outer(count=0), **fields)  # replace checks no types
    assert _checked_error(obj) == reason
    decoded = _decoded_error(obj)
    if "got `dict`" in reason or "got `Other`" in reason:
        # A mapping, or another struct of the same fields, encodes as the struct would: its
        # bytes decode, but the object is not what a reader of the field may use.
        assert decoded is None
    else:
        assert decoded == reason


def test_a_numpy_number_is_refused_as_encoding_refuses_it() -> None:
    obj = msgspec.structs.replace(Outer(count=0), ratio=np.float64(1.0))
    assert _checked_error(obj) == "Expected `float`, got `numpy.float64` - at `$.ratio`"
    with pytest.raises(TypeError, match=r"numpy\.float64 is unsupported"):
        msgspec.msgpack.encode(obj)


def test_the_object_is_left_as_it_is() -> None:
    obj = VALID[1]
    before = msgspec.structs.asdict(obj)
    OUTER.check(obj)
    assert msgspec.structs.asdict(obj) == before
    assert obj.inners[0] is INNER


class Tree(msgspec.Struct):
    children: list[Tree] = []


def test_a_recursive_struct_is_refused_when_its_check_is_built() -> None:
    with pytest.raises(TypeError, match="Tree holds itself: recursive structs are not supported"):
        FieldTypes(Tree)
