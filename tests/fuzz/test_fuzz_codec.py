"""Fuzz the bus codec: every message type's decoder, the JPEG header reader, frame pixels, and
servo commands all the way into the control interface's core (never a servo outside its limits).
"""

from __future__ import annotations

import contextlib
import math
import re
import typing
from pathlib import Path
from typing import Any

import msgspec
import pytest
from fuzzing import FUZZ, TIMEOUT, check_tally, libjpeg_quiet, outcome
from hypothesis import given
from hypothesis import strategies as st
from mutations import damaged, hostile, mutated

from facesynth.runtime import codec
from facesynth.runtime.frames import FrameError, decode_frame
from facesynth.runtime.jpeg import JpegHeaderError, jpeg_size
from facesynth.runtime.profiles import Profile, load_profile
from facesynth.schemas.messages import (
    BabbleSample,
    Features,
    Frame,
    Points,
    ServiceStats,
    ServoCommands,
)
from facesynth.services.control.core import Arrival, CommandError, ControlCore, Move, StaleCommand

pytestmark = [pytest.mark.fuzz, TIMEOUT]

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "messages"
JPEG = (FIXTURES / "frame.jpg").read_bytes()


def _fixture(name: str) -> tuple[bytes, Any]:
    data = (FIXTURES / f"{name}.msgpack").read_bytes()
    return data, msgspec.msgpack.decode(data)


def _msgpack(tree: Any) -> bytes:
    return msgspec.msgpack.encode(tree)


def _strategy(*names: str) -> st.SearchStrategy[bytes]:
    return st.one_of(*(hostile(*_fixture(name), _msgpack) for name in names))


@pytest.mark.parametrize(
    ("cls", "fixtures"),
    [
        (Frame, ("frame_jpeg", "frame_raw")),
        (Points, ("points_face", "points_no_face")),
        (Features, ("features",)),
        (ServiceStats, ("service_stats", "service_stats_idle")),
    ],
    ids=["Frame", "Points", "Features", "ServiceStats"],
)
def test_decode_gives_a_valid_message_or_a_message_error(
    cls: type[Any], fixtures: tuple[str, ...]
) -> None:
    target = f"codec.decode {cls.__name__}"

    @FUZZ
    @given(_strategy(*fixtures))
    def case(payload: bytes) -> None:
        message = outcome(target, lambda: codec.decode(payload, cls), codec.MessageError)
        if message is not None:
            assert isinstance(message, cls)
            assert codec.decode(codec.encode(message), cls) == message  # valid stays valid

    case()
    check_tally(target, "valid", "refused")


# --- JPEG header and frame pixels --------------------------------------------------------------


def _segment(marker: int, body: bytes) -> bytes:
    return bytes([0xFF, marker]) + (len(body) + 2).to_bytes(2, "big") + body


#: JPEG-like headers built from random segments: SOF markers with any size, fill bytes,
#: standalone markers, lengths that lie.
jpeg_like = st.lists(
    st.one_of(
        st.builds(_segment, st.integers(0xC0, 0xFE), st.binary(max_size=24)),
        st.builds(
            lambda h, w: _segment(0xC0, b"\x08" + h.to_bytes(2, "big") + w.to_bytes(2, "big")),
            st.integers(0, 0xFFFF),
            st.integers(0, 0xFFFF),
        ),
        st.sampled_from([b"\xff\xff\xff", b"\xff\xd0", b"\xff\x01", b"\xff\xda", b"\xff\xd9"]),
        st.binary(max_size=6),
    ),
    max_size=6,
).map(lambda parts: b"\xff\xd8" + b"".join(parts))


def test_jpeg_size_reads_a_header_or_raises_jpeg_header_error() -> None:
    target = "jpeg.jpeg_size"

    @FUZZ
    @given(st.one_of(st.binary(max_size=64), damaged(JPEG), jpeg_like))
    def case(data: bytes) -> None:
        size = outcome(target, lambda: jpeg_size(data), JpegHeaderError)
        if size is not None:
            width, height = size
            assert 0 < width <= 0xFFFF and 0 < height <= 0xFFFF

    case()
    check_tally(target, "valid", "refused")


_FRAME_KINDS = st.sampled_from(["jpeg", "jpeg", "raw", "none"])
_JPEG_DATA = st.one_of(damaged(JPEG), st.just(JPEG))


@st.composite
def frames(draw: st.DrawFn) -> Frame:
    """Frames that passed the codec's checks (so their header says their real size), with
    damaged JPEG data or raw pixels."""
    kind = draw(_FRAME_KINDS)
    if kind == "jpeg":
        data = draw(_JPEG_DATA)
        try:
            width, height = jpeg_size(data)
        except JpegHeaderError:
            width, height = 16, 9
    else:
        width, height = draw(st.integers(1, 8)), draw(st.integers(1, 8))
        data = draw(st.binary(min_size=width * height * 3, max_size=width * height * 3))
    return Frame(
        seq=draw(st.integers(0, 10)),
        t_capture_ns=0,
        t_media_ns=0,
        width=width,
        height=height,
        encoding=kind,  # type: ignore[arg-type]
        data=data if kind != "none" else b"",
    )


def test_frame_pixels_decode_or_raise_frame_error() -> None:
    target = "frames.decode_frame"

    @FUZZ
    @given(frames())
    def case(frame: Frame) -> None:
        if (
            outcome(
                f"{target} (codec)",
                lambda: codec.decode(codec.encode(frame), Frame),
                codec.MessageError,
            )
            is None
        ):
            return
        image = outcome(target, lambda: decode_frame(frame), FrameError)
        if image is not None:
            assert image.shape == (frame.height, frame.width, 3)

    with libjpeg_quiet():
        case()
    check_tally(target, "valid", "refused", every_case=False)


# --- servo commands into the control core ------------------------------------------------------

PROFILE = load_profile("paper16")
COMMANDS_SEED = {
    "type": "servo_commands",
    "seq": 7,
    "t_capture_ns": 1_000_000_000,
    "t_media_ns": 500_000_000,
    "face": True,
    "profile": PROFILE.name,
    "positions": {spec.name: spec.neutral_us + 100.0 for spec in PROFILE.servos},
    "sender": "translator-1",
    "sender_seq": 1,
    "sent_ns": 10**18,
    "sender_host": "host-a",
}


def check_within_limits(profile: Profile, move: Move | None) -> None:
    """Every position of ``move`` is a servo of ``profile``, finite and within its limits."""
    if move is None:
        return
    specs = {spec.name: spec for spec in profile.servos}
    assert set(move.positions) <= set(specs)
    for name, value in move.positions.items():
        spec = specs[name]
        assert math.isfinite(value), (name, value)
        assert spec.min_us <= value <= spec.max_us, (move.kind, name, value)


COMMANDS_SEED_BYTES = _msgpack(COMMANDS_SEED)
#: 1..3 payloads (mostly mutated commands for the profile), each with a gap in ms.
command_streams = st.lists(
    st.tuples(
        st.one_of(
            mutated(COMMANDS_SEED, max_changes=2).map(_msgpack),
            mutated(COMMANDS_SEED, max_changes=1).map(_msgpack),
            damaged(COMMANDS_SEED_BYTES),
            st.binary(max_size=64),
            st.just(COMMANDS_SEED_BYTES),
        ),
        st.integers(0, 600),
    ),
    min_size=1,
    max_size=3,
)


def test_servo_commands_decode_and_never_move_a_servo_outside_its_limits() -> None:
    target = "codec.decode ServoCommands"
    core_target = "ControlCore.command"

    @FUZZ
    @given(command_streams)
    def case(stream: list[tuple[bytes, int]]) -> None:
        core = ControlCore(PROFILE)
        now = 10**9
        check_within_limits(PROFILE, core.start(now))
        for payload, gap_ms in stream:
            commands = outcome(
                target, lambda p=payload: codec.decode(p, ServoCommands), codec.MessageError
            )
            if commands is not None:
                arrival = Arrival(wall_ns=10**18 + now, mono_ns=now)
                applied = outcome(
                    core_target,
                    lambda c=commands, a=arrival: core.command(c, a),
                    (CommandError, StaleCommand),
                )
                if applied is not None:
                    check_within_limits(PROFILE, applied[0])
            end = now + gap_ms * 1_000_000
            for _ in range(100):  # the core's own moves until the next command
                due = core.due_ns()
                if due > end:
                    break
                now = max(now, due)
                check_within_limits(PROFILE, core.tick(now))
            now = end
        core.stop(now)
        for _ in range(200):
            if core.stopped:
                break
            now = max(now, core.due_ns())
            check_within_limits(PROFILE, core.tick(now))
        assert core.stopped

    case()
    check_tally(target, "valid", "refused")
    check_tally(core_target, "valid", "refused", every_case=False)


# --- Messages handed over within a process (never encoded): codec.check ---------------------


def _built(payload: bytes, cls: type[Any]) -> Any:
    """The struct a stage of this process could have built from ``payload``'s fields, with
    whatever values they hold (a struct's constructor checks no types), nested structs built
    the same way where their table has their required fields, or ``None``."""
    try:
        tree = msgspec.msgpack.decode(payload)
    except (msgspec.DecodeError, UnicodeDecodeError):
        return None
    return _struct(tree, cls)


def _struct(tree: Any, cls: type[Any]) -> Any:
    if not isinstance(tree, dict):
        return None
    hints = typing.get_type_hints(cls)
    fields = {}
    for name, value in tree.items():
        if name not in cls.__struct_fields__:
            continue
        item = _struct_item(hints[name])
        if item is not None and isinstance(value, list):
            value = [_struct(v, item) or v for v in value]  # what cannot be built stays a table
        fields[name] = value
    try:
        return cls(**fields)
    except TypeError:  # a required field is missing
        return None


def _struct_item(hint: Any) -> type[Any] | None:
    """``S`` for a ``list[S]`` of a struct class ``S``."""
    args = typing.get_args(hint)
    if (
        typing.get_origin(hint) is list
        and args
        and isinstance(args[0], type)
        and issubclass(args[0], msgspec.Struct)
    ):
        return args[0]
    return None


def _family(reason: str) -> str:
    """``reason`` without the name msgspec gives the value it got (a converted None is `null`,
    a decoded one `None`; a set is an `array` once encoded)."""
    return re.sub(r"got `[^`]*`", "got `…`", reason)


def _as_bytes(message: Any, cls: type[Any]) -> tuple[bool, str | None]:
    """Whether ``message``'s bytes can be written within their limit, and what decoding them
    says (``None``: they decode)."""
    try:
        payload = codec.encode(message)
    except (TypeError, ValueError, OverflowError):
        return False, None
    if len(payload) > codec.MAX_BYTES[cls]:
        return False, None
    try:
        codec.decode(payload, cls)
    except codec.MessageError as exc:
        return True, str(exc)
    return True, None


def check_as_its_bytes(message: Any, cls: type[Any]) -> None:
    """An object is refused exactly when its own bytes would be, and a field of the wrong type
    (msgspec's refusal, "not a valid … message: …") in the same words."""
    written, decoded = _as_bytes(message, cls)
    try:
        codec.check(message, cls)
    except codec.MessageError as exc:
        checked: str | None = str(exc)
    else:
        checked = None
    if not written:
        return
    assert (checked is None) == (decoded is None), (checked, decoded)
    prefix = f"not a valid {cls.__name__} message: "
    if decoded is not None and decoded.startswith(prefix):
        assert checked is not None and _family(checked) == _family(decoded)


@pytest.mark.parametrize(
    ("cls", "fixtures"),
    [
        (Frame, ("frame_jpeg", "frame_raw")),
        (Points, ("points_face", "points_no_face")),
        (Features, ("features",)),
        (ServoCommands, ("servo_commands", "servo_commands_sent", "servo_state_own_move")),
        (ServiceStats, ("service_stats", "service_stats_idle")),
        (BabbleSample, ("babble_sample",)),
    ],
    ids=["Frame", "Points", "Features", "ServoCommands", "ServiceStats", "BabbleSample"],
)
def test_an_object_is_refused_exactly_when_its_bytes_would_be(
    cls: type[Any], fixtures: tuple[str, ...]
) -> None:
    # The in-process path checks the object a stage built (codec.check) instead of decoding
    # bytes: it must refuse what decode refuses (within the byte limit, which objects do not
    # have), and refuse anything built with values of the wrong types as its bytes would be
    # refused, in the same words, never crash.
    target = f"codec.check {cls.__name__}"
    core = ControlCore(PROFILE)
    now = 10**9
    core.start(now)

    @FUZZ
    @given(_strategy(*fixtures))
    def case(payload: bytes) -> None:
        built = _built(payload, cls)
        if built is not None:
            checked = outcome(target, lambda: codec.check(built, cls), codec.MessageError)
            if checked is not None and cls is ServoCommands:
                arrival = Arrival(wall_ns=10**18 + now, mono_ns=now)
                with contextlib.suppress(CommandError, StaleCommand):
                    check_within_limits(PROFILE, core.command(checked, arrival)[0])
            check_as_its_bytes(built, cls)
        try:
            typed = msgspec.msgpack.decode(payload, type=cls)  # types checked, nothing else
        except (msgspec.DecodeError, msgspec.ValidationError, UnicodeDecodeError):
            return
        if len(payload) > codec.MAX_BYTES[cls]:
            return
        try:
            codec.decode(payload, cls)
        except codec.MessageError:
            with pytest.raises(codec.MessageError):
                codec.check(typed, cls)
        else:
            assert codec.check(typed, cls) is typed

    case()
    check_tally(target, "valid", "refused", every_case=False)
