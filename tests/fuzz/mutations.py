"""Hypothesis strategies for hostile input: raw bytes, and valid input broken in structured ways.

* :func:`damaged` — valid bytes truncated, bit-flipped, spliced with random bytes or repeated;
* :func:`mutated` — a valid value tree (dicts and lists, as decoded from msgpack, JSON or TOML)
  with a few nodes replaced by wrong types, NaN/inf, negative or huge numbers, huge strings or
  lists, removed or added keys;
* :func:`hostile` — one of those or random bytes, so a target sees all three kinds.
"""

from __future__ import annotations

import copy
import json
import math
from typing import Any

import msgspec
from hypothesis import strategies as st

#: Values that break assumptions: wrong types, non-finite and extreme numbers, empty and big.
NASTY_SCALARS: list[Any] = [
    math.nan,
    math.inf,
    -math.inf,
    -1,
    0,
    1,
    -1.5,
    2**31,
    2**63 - 1,
    -(2**63),
    2**64 - 1,
    1e308,
    -1e308,
    5e-324,
    "",
    "x" * 300,
    "\u0000\ud7ff\U0010ffff",
    None,
    True,
    False,
    [],
    {},
    [1.0] * 2000,
    {"k": 1.0},
]

nasty = st.one_of(
    st.sampled_from(NASTY_SCALARS),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-(2**63), 2**64 - 1),
    st.text(max_size=12),
    st.lists(st.floats(), max_size=6),
    st.lists(st.integers(-5, 5000), max_size=6),
)


def _paths(tree: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every node's path (keys and indices) in a tree of dicts and lists, sampled thinly in
    long lists so a mesh of 1,434 numbers does not drown the few fields that matter."""
    found = [prefix]
    if isinstance(tree, dict):
        for key, value in tree.items():
            found += _paths(value, (*prefix, key))
    elif isinstance(tree, list):
        indices = range(len(tree)) if len(tree) <= 8 else (0, 1, len(tree) // 2, len(tree) - 1)
        for index in indices:
            found += _paths(tree[index], (*prefix, index))
    return found


def _parent(tree: Any, path: tuple[Any, ...]) -> Any:
    node = tree
    for step in path[:-1]:
        node = node[step]
    return node


def _copy(tree: Any) -> Any:
    """A deep copy of a tree of plain values (through msgpack: many times faster than
    ``copy.deepcopy`` on a face mesh)."""
    try:
        return msgspec.msgpack.decode(msgspec.msgpack.encode(tree))
    except (TypeError, OverflowError, msgspec.EncodeError):
        return copy.deepcopy(tree)


# The strategies drawn inside the composites below, built once: one built inside a draw is a
# new object every time, built and validated by hypothesis again for every case.
_ACTIONS = st.sampled_from(["replace", "replace", "replace", "delete", "grow", "add"])
_GROWTH = st.sampled_from([0, 2, 3, 50])
_NEW_KEYS = st.text(min_size=1, max_size=8)
_DAMAGES = st.sampled_from(["truncate", "flip", "flip", "splice", "repeat"])
_BITS = st.integers(0, 7)
_SPLICES = st.binary(max_size=16)
_REPEATS = st.integers(1, 4)
_REPEATED = st.integers(1, 64)
_DAMAGE_COUNT = st.integers(1, 3)


def _index(draw: st.DrawFn, size: int) -> int:
    """An index below ``size`` (``st.integers`` strategies are cached by their bounds; a
    ``st.sampled_from`` of the paths would be a new strategy for every draw)."""
    return draw(st.integers(0, size - 1))


def _fresh(value: Any) -> Any:
    """A copy of a drawn nasty value (never the shared constants themselves)."""
    return _copy(value) if isinstance(value, list | dict) else value


@st.composite
def mutated(draw: st.DrawFn, valid: Any, max_changes: int = 3) -> Any:
    """A deep copy of ``valid`` with 1..``max_changes`` nodes changed."""
    tree = _copy(valid)
    for _ in range(draw(st.integers(1, max_changes))):
        paths = [p for p in _paths(tree) if p]
        if not paths:
            return _fresh(draw(nasty))
        path = paths[_index(draw, len(paths))]
        parent = _parent(tree, path)
        key = path[-1]
        action = draw(_ACTIONS)
        if action == "replace":
            parent[key] = _fresh(draw(nasty))
        elif action == "delete":
            del parent[key]
        elif action == "grow" and isinstance(parent[key], list | str):
            parent[key] = _fresh(parent[key] * draw(_GROWTH))
        elif isinstance(parent, dict):
            parent[draw(_NEW_KEYS)] = _fresh(draw(nasty))
        elif isinstance(parent, list):
            parent.insert(key, _fresh(draw(nasty)))
    return tree


@st.composite
def damaged(draw: st.DrawFn, valid: bytes) -> bytes:
    """``valid`` truncated, with bits flipped, with random bytes spliced in, or repeated."""
    data = bytearray(valid)
    for _ in range(draw(_DAMAGE_COUNT)):
        kind = draw(_DAMAGES)
        if not data:
            data += draw(_SPLICES)
            continue
        at = draw(st.integers(0, len(data) - 1))
        if kind == "truncate":
            del data[at:]
        elif kind == "flip":
            data[at] ^= 1 << draw(_BITS)
        elif kind == "splice":
            end = draw(st.integers(at, min(len(data), at + 16)))
            data[at:end] = draw(_SPLICES)
        else:
            data[at:at] = data[at : at + draw(_REPEATED)] * draw(_REPEATS)
    return bytes(data)


def hostile(valid_bytes: bytes, tree: Any, encode: Any, raw_size: int = 256) -> Any:
    """Random bytes, damaged valid bytes, or a mutated tree encoded with ``encode`` (itself
    allowed to fail for values its format cannot hold: those cases are dropped)."""
    return st.one_of(
        st.binary(max_size=raw_size),
        damaged(valid_bytes),
        mutated(tree).map(encode),
        mutated(tree).map(encode),
        st.just(valid_bytes),
    )


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        return repr(value) if math.isfinite(value) else ("inf" if value > 0 else "-inf")
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value if v is not None) + "]"
    if isinstance(value, dict):
        items = [
            f"{json.dumps(str(k))} = {_toml_value(v)}" for k, v in value.items() if v is not None
        ]
        return "{" + ", ".join(items) + "}"
    return json.dumps(str(value))


def to_toml(tree: Any) -> str:
    """``tree`` (a dict) as TOML text: one ``key = inline value`` line per key (``None``s
    dropped: TOML has no null); anything else becomes a document TOML refuses."""
    if not isinstance(tree, dict):
        return f"= {tree!r}\n"
    lines = [f"{json.dumps(str(k))} = {_toml_value(v)}\n" for k, v in tree.items() if v is not None]
    return "".join(lines)


def to_json(tree: Any) -> bytes:
    """``tree`` as JSON bytes (NaN and infinities as the bare words JSON does not allow)."""
    return json.dumps(tree, allow_nan=True).encode()


@st.composite
def damaged_text(draw: st.DrawFn, valid: str) -> str:
    """:func:`damaged` for text (invalid UTF-8 replaced)."""
    return draw(damaged(valid.encode())).decode("utf-8", "replace")
