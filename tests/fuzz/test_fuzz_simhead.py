"""Fuzz the simulated head (facesynth.app.simhead): its head files (TOML) and the Maestro
protocol it speaks on its serial port.

* Head files: the bundled heads mutated (generic mutations, and up to three actuator fields
  set to edge values of their schema, or just beyond), damaged or random, parsed from text or
  loaded from a file: a :class:`HeadConfig` or a :class:`HeadError`. Every valid head builds
  a :class:`SimHead` that is commanded (any pulse, channel and off) and stepped (time standing
  still, jumping): ``pulses``, ``positions``, ``outputs`` and ``activations`` stay finite,
  each skin within its actuator's range and each output within its gain. Rendering is left
  out: drawing a frame takes milliseconds (OpenCV warps of the bundled photo), far too slow
  for 10,000 cases, and it only reads the activations checked here
  (tests/app/simhead/test_simhead_render.py draws).
* The Maestro (:class:`~facesynth.app.simhead.maestro.Maestro`): streams of commands in both
  protocols (any channel, value, device number; some damaged) mixed with random bytes, fed in
  chunks with the ramps stepped in between, then its outputs driving a head as
  ``facesynth simhead`` does. ``feed`` and ``step`` never raise (a malformed byte is a
  protocol error in the error register, not an exception); every answer has the length its
  query gives and a value it can have; targets and outputs are off or within 500..2500 µs; a
  stream of well-formed commands for this model and device raises no protocol error.
"""

from __future__ import annotations

import copy
import math
import tomllib
from pathlib import Path
from typing import Any

import pytest
from fuzzing import FUZZ, TIMEOUT, check_tally, outcome, scratch_folder, tally
from hypothesis import given
from hypothesis import strategies as st
from mutations import damaged, damaged_text, mutated, to_toml

from facesynth.app.simhead.config import HeadConfig, HeadError, parse_head
from facesynth.app.simhead.head import CHANNELS, SimHead
from facesynth.app.simhead.heads import head_names, load_head
from facesynth.app.simhead.maestro import (
    GET_ERRORS,
    GET_MOVING_STATE,
    GET_POSITION,
    GO_HOME,
    MAX_TARGET,
    MIN_TARGET,
    POLOLU_START,
    PROTOCOL_ERROR,
    SET_ACCELERATION,
    SET_MULTIPLE_TARGETS,
    SET_SPEED,
    SET_TARGET,
    Maestro,
)

pytestmark = [pytest.mark.fuzz, TIMEOUT]

HEAD_FILES = [
    Path(__file__).resolve().parents[2] / "facesynth/app/simhead/data/heads" / f"{name}.toml"
    for name in head_names()
]
HEAD_TEXTS = [path.read_text() for path in HEAD_FILES]
#: Each bundled head cut to its first four actuators for the mutations (between them every
#: curve, reversed and not, and a dead channel): a 16-actuator file costs four times as much
#: TOML to write and parse per case, and the actuators are checked one by one alike.
HEAD_TREES = [
    {**tree, "actuators": tree["actuators"][:4]} for tree in map(tomllib.loads, HEAD_TEXTS)
]

#: Edge values of each actuator field, allowed by its schema or just beyond.
EDGES: dict[str, list[Any]] = {
    "channel": [0, 23, 24, -1],
    "min_us": [500.0, 2500.0, 499.9, 1499.0],
    "max_us": [500.0, 2500.0, 2500.1, 1501.0],
    "rest_us": [500.0, 2500.0, 1000.0001, 1999.9999],
    "dead_band_us": [0.0, 5e-324, 499.0, 1e308],
    "curve": ["linear", "power", "smoothstep", "cubic"],
    "exponent": [5e-324, 1e-9, 5.0, 5.0000001],
    "gain_up": [0.0, 3.0, 5e-324, -0.0],
    "gain_down": [0.0, 3.0, 5e-324, 3.0000001],
    "reversed": [True, False],
    "slew_us_per_s": [5e-324, 1e-300, 1e308, math.inf],
    "lag_s": [0.0, 5e-324, 2.0, 1e-300],
    "effects": [{}, {"jaw": 3.0, "brow_inner": -3.0}, {"jaw": 3.1}],
    "coupling": [{}, {"gaze_left_x": -3.0, "mouth_smile": 3.0}],
}


# What an edge head draws from, built once (not again inside every draw).
_HEADS = st.sampled_from(HEAD_TREES)
_EDITS = st.integers(1, 3)
_FIELDS = st.sampled_from(sorted(EDGES))
_EDGE_VALUES = {field: st.sampled_from(values) for field, values in EDGES.items()}


@st.composite
def edge_heads(draw: st.DrawFn) -> str:
    """A bundled head with one to three actuator fields set to edge values."""
    head = copy.deepcopy(draw(_HEADS))
    for _ in range(draw(_EDITS)):
        actuators = head["actuators"]
        actuator = actuators[draw(st.integers(0, len(actuators) - 1))]
        field = draw(_FIELDS)
        actuator[field] = draw(_EDGE_VALUES[field])
    return to_toml(head)


head_texts = st.one_of(
    st.sampled_from(HEAD_TREES).flatmap(lambda tree: mutated(tree)).map(to_toml),
    st.sampled_from(HEAD_TREES).flatmap(lambda tree: mutated(tree)).map(to_toml),
    edge_heads(),
    edge_heads(),
    st.sampled_from(HEAD_TEXTS).flatmap(damaged_text),
    st.text(max_size=200),
)

#: Moves a head is put through: (channel, pulse µs) commands and time steps (ns), each
#: one draw (drawing costs more than the head here).
MOVES = st.lists(
    st.sampled_from(
        [
            *(
                (channel, pulse)
                for channel in range(CHANNELS)
                for pulse in [0.0, 1.0, 499.0, 500.0, 1500.0, 2500.0, 1e9, 1e308, 5e-324]
            ),
            *[0, 1, 10_000_000, 33_333_333, 10**9, 10**15] * 8,
        ]
    ),
    max_size=8,
)


def exercise(config: HeadConfig, moves: list[Any]) -> None:
    """A head of ``config`` through ``moves``: everything it reports finite and in range."""
    head = SimHead(config)  # no renderer: never drawn (see the module doc)
    actuators = config.by_channel()
    t_ns = 0
    for move in [*moves, 50_000_000]:
        if isinstance(move, tuple):
            head.command(*move)
        else:
            t_ns += move
            head.step(t_ns)
        assert all(math.isfinite(v) and v >= 0 for v in head.pulses().values())
        for channel, skin in head.positions().items():
            a = actuators[channel]
            assert math.isfinite(skin) and a.min_us <= skin <= a.max_us, (channel, skin)
        for channel, value in head.outputs().items():
            a = actuators[channel]
            assert -max(a.gain_up, a.gain_down) <= value <= max(a.gain_up, a.gain_down)
        assert all(math.isfinite(v) for v in head.activations().values())
        head.moving()


def test_heads_load_or_raise_head_error() -> None:
    target = "simhead.parse_head + SimHead"
    folder = scratch_folder("fuzz-head-")
    file = folder / "head.toml"

    @FUZZ
    @given(head_texts, st.sampled_from([1, 2, 3, 4, 5, 6, 7, 0]), MOVES)
    def case(text: str, via: int, moves: list[Any]) -> None:
        if via == 0:  # load_head from a file: 1 in 8 (writing is slower than parsing)
            file.write_text(text, encoding="utf-8", errors="surrogatepass")
            config = outcome(target, lambda: load_head(file), HeadError)
        else:
            config = outcome(target, lambda: parse_head(text), HeadError)
        if config is not None:
            exercise(config, moves)

    case()
    check_tally(target, "valid", "refused")


# --- the Maestro protocol ----------------------------------------------------------------------


def _u14(value: int) -> bytes:
    return bytes((value & 0x7F, (value >> 7) & 0x7F))


COMMANDS = [
    SET_TARGET,
    SET_TARGET,
    SET_SPEED,
    SET_ACCELERATION,
    GET_POSITION,
    GET_MOVING_STATE,
    SET_MULTIPLE_TARGETS,
    GET_ERRORS,
    GO_HOME,
]
#: 14-bit values: off, the clamp's edges, an acceleration's limit, and a spread between.
VALUES = sorted({0, 1, 255, 256, 1999, 2000, 6000, 10000, 10001, 0x3FFF, *range(0, 0x4000, 331)})
#: A command as drawn, as one number (drawing dominates this target's time): which, a channel
#: selector, a value, the protocol (0, 1: compact; 2: Pololu for this device; 3: Pololu for
#: another) and a Set Multiple Targets count.
FIELDS = (len(COMMANDS), 256, len(VALUES), 4, 9)
COMMAND = st.integers(0, math.prod(FIELDS) - 1)


def _fields(code: int) -> tuple[int, int, int, int, int]:
    """The fields a :data:`COMMAND` number stands for."""
    digits = []
    for size in FIELDS:
        code, digit = divmod(code, size)
        digits.append(digit)
    which, selector, value, protocol, count = digits
    return COMMANDS[which], selector, VALUES[value], protocol, count


def maestro_command(
    drawn: tuple[int, int, int, int, int], channels: int, device: int
) -> tuple[bytes, bool]:
    """A drawn command's bytes for a Maestro of ``channels`` channels and ``device`` number,
    and whether it is well formed for it (which a Maestro must take without an error)."""
    command, selector, value, protocol, count = drawn
    # mostly a channel of this model (the last one included), sometimes any up to 127
    channel = selector % channels if selector < 200 else selector - 128
    fits = channel < channels
    if command in (SET_TARGET, SET_SPEED, SET_ACCELERATION):
        data = bytes((channel,)) + _u14(value)
        fits = fits and (command != SET_ACCELERATION or value <= 255)
    elif command == GET_POSITION:
        data = bytes((channel,))
    elif command == SET_MULTIPLE_TARGETS:
        values = [(value + 4099 * k) % 0x4000 for k in range(count)]
        data = bytes((count, channel)) + b"".join(_u14(v) for v in values)
        fits = fits and channels > 6 and count > 0 and channel + count <= channels
    else:
        data = b""
        fits = True
    if protocol >= 2:  # the Pololu protocol: this device's packet, or another's (skipped)
        number = device if protocol == 2 else (device + 1) % 128
        return bytes((POLOLU_START, number, command & 0x7F)) + data, fits or protocol == 3
    return bytes((command,)) + data, fits


# What a Maestro stream draws from, built once (not again inside every draw).
_CHANNELS = st.sampled_from([6, 12, 18, 24])
_DEVICES = st.sampled_from([12, 12, 0, 127, 5])
_KINDS = st.sampled_from(["clean", "clean", "damaged", "mixed", "random"])
_RANDOM = st.binary(max_size=64)
_COMMANDS = st.lists(COMMAND, min_size=1, max_size=8)
_NOISE = st.binary(min_size=1, max_size=8)
_PIECE_SIZES = st.integers(1, 16)


@st.composite
def maestro_streams(draw: st.DrawFn) -> tuple[int, int, list[bytes], bool]:
    """A Maestro (channels, device number), the chunks written to it, and whether they are
    all well-formed commands for it."""
    channels = draw(_CHANNELS)
    device = draw(_DEVICES)
    kind = draw(_KINDS)
    parts: list[bytes] = []
    clean = True
    if kind == "random":
        parts.append(draw(_RANDOM))
        clean = False
    else:
        for code in draw(_COMMANDS):
            command, fits = maestro_command(_fields(code), channels, device)
            clean &= fits
            parts.append(command)
        if kind == "damaged":
            at = draw(st.integers(0, len(parts) - 1))
            parts[at] = draw(damaged(parts[at]))
            clean = False
        elif kind == "mixed":
            parts.insert(draw(st.integers(0, len(parts))), draw(_NOISE))
            clean = False
    stream = b"".join(parts)
    size = draw(_PIECE_SIZES)  # as the pseudo-terminal delivers it: in pieces
    return channels, device, [stream[at : at + size] for at in range(0, len(stream), size)], clean


#: Bytes each query answers with (the others answer nothing).
ANSWERS = {GET_POSITION: 2, GET_MOVING_STATE: 1, GET_ERRORS: 2}
HEAD = load_head("simhead16")


def _read_answers(maestro: Maestro, executed: list[tuple[int, ...]], answer: bytes) -> None:
    """Walk the answers in the order of the commands executed: each of the right length
    and a value it can have (an out-of-range Get Position answers nothing: an error)."""
    at = 0
    for packet in executed:
        command = packet[0]
        if command == GET_POSITION and packet[1] >= maestro.channels:
            continue
        size = ANSWERS.get(command, 0)
        value = int.from_bytes(answer[at : at + size], "little")
        assert len(answer[at : at + size]) == size, (packet, answer)
        if command == GET_POSITION:
            assert value == 0 or MIN_TARGET <= value <= MAX_TARGET
        elif command == GET_MOVING_STATE:
            assert value in (0, 1)
        elif command == GET_ERRORS:
            assert value & ~PROTOCOL_ERROR == 0
        at += size
    assert at == len(answer), (executed, answer)


def test_maestro_answers_and_clamps_any_byte_stream() -> None:
    target = "simhead Maestro.feed + SimHead"
    record = tally(target)

    @FUZZ
    @given(maestro_streams(), st.lists(st.sampled_from([0, 1, 5_000_000, 10**9]), max_size=4))
    def case(stream: tuple[int, int, list[bytes], bool], steps: list[int]) -> None:
        channels, device, chunks, clean = stream
        maestro = Maestro(channels=channels, device_number=device)
        head = SimHead(HEAD)
        t_ns = 0
        for index, chunk in enumerate(chunks):
            before = len(maestro.commands)
            answer = maestro.feed(chunk)
            _read_answers(maestro, maestro.commands[before:], answer)
            t_ns += steps[index % len(steps)] if steps else 0
            maestro.step(t_ns)
            for channel, pulse in maestro.outputs().items():  # as facesynth simhead does
                head.command(channel, pulse)
            head.step(t_ns)
        for values in (maestro.targets(), maestro.outputs()):
            assert set(values) == set(range(channels))
            assert all(v == 0 or 500.0 <= v <= 2500.0 for v in values.values()), values
        for channel, skin in head.positions().items():
            assert HEAD.by_channel()[channel].min_us <= skin <= HEAD.by_channel()[channel].max_us
        for channel in range(channels):
            speed, acceleration = maestro.limits(channel)
            assert 0 <= speed <= 0x3FFF and 0 <= acceleration <= 255
        assert maestro.errors in (0, PROTOCOL_ERROR)
        assert maestro.error_events > 0 or not maestro.errors
        if clean:
            assert maestro.error_events == 0, chunks
            record.count("well-formed")
        else:
            record.count("protocol error" if maestro.error_events else "malformed, no error")

    case()
    check_tally(target, "well-formed", "protocol error", "malformed, no error")
