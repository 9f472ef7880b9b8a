"""Check every field of a struct built in this process for its declared type, as decoding its
bytes would check it.

A struct's constructor checks no types: ``Points(face="yes", ...)`` builds. Bytes decoded with
msgspec are checked field by field (types, nested structs, lists, tuples and tables, optional
fields, ``Literal`` values, constraints declared with ``msgspec.Meta``); an object handed over
within a process (:func:`facesynth.runtime.codec.check`) gets the same checks here, with the same
error text (``Expected `float`, got `str` - at `$.positions[...]```; msgspec names a received
``None`` `null` here, `None` when decoding, and a path names a renamed field by its attribute).

``msgspec.convert`` returns an object of the target type unchanged, so :class:`FieldTypes`
converts the object, by its attributes, into a *shadow* struct built once per class: the same
fields with the same annotations, nested struct classes replaced by their own shadows. msgspec
does that in C (2 µs of CPU for a ServoCommands, 12 for a Features, 15 for a Points message
with a face mesh and blendshapes: cheaper than msgpack there and back). A shadow
also takes a mapping or any object with the right attributes where a nested struct is declared,
so each nested value is then also checked to be an instance of its declared class. The shadow's
fields keep their defaults, so a mapping lacking one is refused for its type, not its keys.
"""

from __future__ import annotations

import types
import typing
from collections.abc import Callable
from typing import Annotated, Any, Literal, Union, get_args, get_origin

import msgspec

#: Checks that a (shadow-checked) value holds instances of its declared struct classes, given
#: the value and its path (``$.sets[0]``); raises ``msgspec.ValidationError``.
_Instances = Callable[[Any, str], None]

_SEQUENCES = (list, tuple, set, frozenset)
#: Binary types msgpack carries as they are: ``convert`` would otherwise take a base64 string
#: for ``bytes``, which decoding never does.
_BINARY = (bytes, bytearray, memoryview)


class FieldTypes:
    """The declared field types of one struct class, checked on objects of it.

    Built once per class (it builds the shadow structs); :meth:`check` is then cheap. Recursive
    struct classes are not supported (facesynth's messages have none).
    """

    def __init__(self, cls: type[msgspec.Struct]) -> None:
        self.cls = cls
        self._shadow = _shadow(cls, {})
        self._nested = _struct_fields(cls)

    def check(self, obj: msgspec.Struct) -> None:
        """Raise ``msgspec.ValidationError`` (msgspec's own text, path from ``$``) unless every
        field of ``obj`` holds a value its bytes would decode to."""
        msgspec.convert(obj, self._shadow, from_attributes=True, builtin_types=_BINARY)
        for name, instances in self._nested:
            instances(getattr(obj, name), f"$.{name}")


def _shadow(
    cls: type[msgspec.Struct], made: dict[type[Any], type[msgspec.Struct] | None]
) -> type[Any]:
    """A plain struct with ``cls``'s fields and annotations, its nested structs shadowed too."""
    if cls in made:
        shadow = made[cls]
        if shadow is None:
            raise TypeError(f"{cls.__name__} holds itself: recursive structs are not supported")
        return shadow
    made[cls] = None  # being made
    hints = typing.get_type_hints(cls, include_extras=True)
    names = cls.__struct_fields__
    defaults = dict(
        zip(
            names[len(names) - len(cls.__struct_defaults__) :],
            cls.__struct_defaults__,
            strict=True,
        )
    )
    fields = [
        (name, _shadowed(hints[name], made), defaults[name])
        if name in defaults
        else (name, _shadowed(hints[name], made))
        for name in names
    ]
    shadow = made[cls] = msgspec.defstruct(f"{cls.__name__}Fields", fields, kw_only=True)
    return shadow


def _shadowed(hint: Any, made: dict[type[Any], type[msgspec.Struct] | None]) -> Any:
    """``hint`` with every struct class in it replaced by its shadow."""
    if isinstance(hint, type) and issubclass(hint, msgspec.Struct):
        return _shadow(hint, made)
    origin, args = get_origin(hint), get_args(hint)
    if origin is None or origin is Literal or not args:
        return hint
    if origin is Annotated:
        return Annotated[(_shadowed(args[0], made), *hint.__metadata__)]
    inner = tuple(_shadowed(arg, made) for arg in args)
    if origin in (Union, types.UnionType):
        return Union[inner]  # noqa: UP007 (built from a tuple of arms)
    if inner == args:
        return hint
    return origin[inner if len(inner) > 1 else inner[0]]


def _struct_fields(cls: type[msgspec.Struct]) -> list[tuple[str, _Instances]]:
    """The fields of ``cls`` whose type holds a struct class, each with its instance check."""
    hints = typing.get_type_hints(cls, include_extras=True)
    found = []
    for name in cls.__struct_fields__:
        instances = _instances(hints[name])
        if instances is not None:
            found.append((name, instances))
    return found


def _instances(hint: Any) -> _Instances | None:
    """The instance check of values of ``hint``, or ``None`` where it names no struct class.
    Runs after the shadow's check, so containers are of their declared kinds."""
    if isinstance(hint, type) and issubclass(hint, msgspec.Struct):
        return _struct_instance(hint)
    origin, args = get_origin(hint), get_args(hint)
    if origin is None or origin is Literal or not args:
        return None
    if origin is Annotated:
        return _instances(args[0])
    if origin in (Union, types.UnionType):
        return _union(args)
    if origin is dict or (isinstance(origin, type) and issubclass(origin, dict)):
        values = _instances(args[-1])
        return None if values is None else _each_value(values)
    if origin is tuple and not (len(args) == 2 and args[1] is Ellipsis):
        positions = [_instances(arg) for arg in args]
        if all(p is None for p in positions):
            return None
        return _each_position(positions)
    items = _instances(args[0])
    return None if items is None else _each_item(items)


def _struct_instance(cls: type[msgspec.Struct]) -> _Instances:
    nested = _struct_fields(cls)

    def check(value: Any, path: str) -> None:
        if not isinstance(value, cls):
            raise msgspec.ValidationError(
                f"Expected `{cls.__name__}`, got `{type(value).__name__}` - at `{path}`"
            )
        for name, instances in nested:
            instances(getattr(value, name), f"{path}.{name}")

    return check


def _union(args: tuple[Any, ...]) -> _Instances | None:
    arms = [(_kinds(arg), _instances(arg)) for arg in args if arg is not type(None)]
    structs = [(kinds, check) for kinds, check in arms if check is not None]
    if not structs:
        return None
    others = tuple(kind for kinds, check in arms if check is None for kind in kinds)

    def check(value: Any, path: str) -> None:
        if value is None:
            return
        for kinds, arm in structs:
            if isinstance(value, kinds):
                arm(value, path)
                return
        if not isinstance(value, others):
            structs[0][1](value, path)  # a mapping taken for the struct: names what was expected

    return check


def _kinds(hint: Any) -> tuple[type[Any], ...]:
    """The Python classes a value of ``hint`` is an instance of (an int is a float's too)."""
    origin, args = get_origin(hint), get_args(hint)
    if origin is Annotated:
        return _kinds(args[0])
    if origin is Literal:
        return tuple({type(arg) for arg in args})
    if origin in (Union, types.UnionType):
        return tuple(kind for arg in args for kind in _kinds(arg))
    kind = origin if isinstance(origin, type) else hint
    if kind is float:
        return (float, int)
    return (kind,) if isinstance(kind, type) else (object,)


def _each_item(items: _Instances) -> _Instances:
    def check(value: Any, path: str) -> None:
        if isinstance(value, _SEQUENCES):
            for index, item in enumerate(value):
                items(item, f"{path}[{index}]")

    return check


def _each_position(positions: list[_Instances | None]) -> _Instances:
    def check(value: Any, path: str) -> None:
        for index, (item, position) in enumerate(zip(value, positions, strict=False)):
            if position is not None:
                position(item, f"{path}[{index}]")

    return check


def _each_value(values: _Instances) -> _Instances:
    def check(value: Any, path: str) -> None:
        for item in value.values():
            values(item, f"{path}[...]")  # msgspec's path of a table's value

    return check
