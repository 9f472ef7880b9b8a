"""F's learned neutral and ranges, kept per rig and performer: a restarted F picks them up.

Without a calibration, F learns the performer's neutral from the first second with a face (and,
with ``auto_range``, keeps adapting it and the feature ranges). A restarted F used to learn it
again from whatever face it saw next: the same frames then mapped a mean 252 µs away. Now the
features service writes what it learned to ``<state dir>/<rig>/<performer>.json`` (atomically:
a kill never leaves half a file), when it learns it and every ``SAVE_INTERVAL_S`` while
``auto_range`` moves it, and reads it back at start. The state directory is ``--state-dir``,
else ``$FACESYNTH_STATE``, else ``~/.config/facesynth/state``.

:func:`snapshot` and :func:`restore` are pure (processor ↔ :class:`LearnedState`);
:func:`load_state` and :func:`save_state` do the file work.
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path
from typing import Literal

import msgspec
import numpy as np

from facesynth.runtime.atomic import write_atomic
from facesynth.runtime.calibration import MAX_VALUE, finite_within
from facesynth.runtime.feature_names import NAMES
from facesynth.runtime.landmarks import N_IBUG
from facesynth.runtime.oneline import one_line
from facesynth.services.features.core import FeatureProcessor
from facesynth.services.features.neutral import AutoNeutral
from facesynth.services.features.pose import N_MESH, MeshReference, PoseError

#: While ``auto_range`` adapts the neutral and ranges, they are written at most this often.
SAVE_INTERVAL_S = 10.0
#: What a performer (and a rig) may be called: it becomes a file name.
NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")


class StateError(ValueError):
    """A learned-state file or name that cannot be used; the message says which and why."""


class LearnedState(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """What F learned of one performer on one rig (see the module doc)."""

    format: Literal["facesynth.features.state"] = "facesynth.features.state"
    version: int = 1
    rig: str
    performer: str
    #: Wall clock (ns) when this was learned or last updated.
    updated_ns: int
    #: The neutral's 68 nose-tip distances (IOD units).
    neutral: list[float]
    #: The neutral's 68 points in the eye-corner frame, flattened x0, y0, x1, …
    frame: list[float]
    #: The neutral's named raw values.
    named_neutral: dict[str, float] = {}
    #: The neutral mesh (468 x 3, flattened), or none (named features from 2D points).
    neutral_mesh: list[float] = []
    #: Each named feature's range relative to the neutral, [min, max].
    ranges: dict[str, tuple[float, float]] = {}


def check_name(name: str, what: str) -> str:
    """``name`` if it can be a file name of the state directory, else raise :class:`StateError`."""
    if not NAME.match(name):
        raise StateError(
            f"{what} {name!r} cannot name a state file: use letters, digits, '_', '.', '-' "
            "(up to 64, starting with a letter or digit)"
        )
    return name


def default_state_dir() -> Path:
    """``$FACESYNTH_STATE``, else ``~/.config/facesynth/state``."""
    env = os.environ.get("FACESYNTH_STATE")
    return Path(env) if env else Path.home() / ".config" / "facesynth" / "state"


def state_path(state_dir: str | Path | None, rig: str, performer: str) -> Path:
    """Where the state of ``performer`` on ``rig`` is kept."""
    base = Path(state_dir) if state_dir is not None else default_state_dir()
    return base / check_name(rig, "rig") / f"{check_name(performer, 'performer')}.json"


# --- pure: processor <-> state ---------------------------------------------------------------


def snapshot(processor: FeatureProcessor, rig: str, performer: str, now_ns: int) -> LearnedState:
    """The processor's learned neutral and ranges, or raise :class:`StateError` before it has
    learned them (:func:`learned`)."""
    if not learned(processor):
        raise StateError("the neutral is not learned yet")
    neutral = processor.estimator.neutral
    frame = processor.frame_neutral
    assert neutral is not None and frame is not None
    named = dict(processor.named_neutral or {})
    ranges = dict(processor.ranges)
    auto = processor.auto
    if auto is not None:  # the rolling neutral and adapted ranges as of now
        named = dict(auto.named)
        ranges = auto.range.ranges()
        values = auto.rolling.neutral
        n = len(NAMES)
        neutral = values[n : n + N_IBUG]
        frame = values[n + N_IBUG :].reshape(N_IBUG, 2)
    reference = processor.reference
    return LearnedState(
        rig=rig,
        performer=performer,
        updated_ns=now_ns,
        neutral=[float(v) for v in neutral],
        frame=[float(v) for v in np.asarray(frame).ravel()],
        named_neutral=named,
        neutral_mesh=[float(v) for v in reference.mesh.ravel()] if reference is not None else [],
        ranges={name: (float(lo), float(hi)) for name, (lo, hi) in ranges.items()},
    )


def learned(processor: FeatureProcessor) -> bool:
    """Whether the processor knows its neutral (distances, points and named values)."""
    return (
        processor.estimator.neutral is not None
        and processor.frame_neutral is not None
        and processor.named_neutral is not None
    )


def restore(processor: FeatureProcessor, state: LearnedState) -> None:
    """Give ``processor`` (without a calibration) the neutral and ranges of ``state``: it
    neither waits for a neutral nor learns one again."""
    problems = validate_state(state)
    if problems:
        raise StateError("; ".join(problems))
    neutral = np.asarray(state.neutral, dtype=np.float64)
    frame = np.asarray(state.frame, dtype=np.float64).reshape(N_IBUG, 2)
    processor.estimator.neutral = neutral
    processor.frame_neutral = frame
    processor.window.samples = []
    processor.named_neutral = dict(state.named_neutral)
    processor.reference = None
    if state.neutral_mesh:
        mesh = np.asarray(state.neutral_mesh, dtype=np.float64).reshape(N_MESH, 3)
        try:
            processor.reference = MeshReference(mesh)
        except PoseError as exc:
            raise StateError(f"neutral_mesh: {exc}") from None
    processor.use_mesh = processor.reference is not None
    ranges = dict(processor.ranges)
    ranges.update({name: (lo, hi) for name, (lo, hi) in state.ranges.items()})
    processor.ranges = ranges
    if processor.auto_range:
        processor.auto = AutoNeutral(processor.named_neutral, neutral, frame, ranges)


def validate_state(state: LearnedState) -> list[str]:
    """Every problem of a parsed state (empty when it can be used)."""
    problems = []
    if state.version != 1:
        problems.append(f"version {state.version} is not supported (this facesynth reads 1)")
    for field, count in (("neutral", N_IBUG), ("frame", 2 * N_IBUG)):
        values = getattr(state, field)
        if len(values) != count:
            problems.append(f"{field} has {len(values)} values, needs {count}")
        elif not finite_within(values):
            problems.append(
                f"{field} has a value that is not a finite number within ±{MAX_VALUE:g}"
            )
    if state.neutral_mesh and len(state.neutral_mesh) != N_MESH * 3:
        problems.append(f"neutral_mesh has {len(state.neutral_mesh)} values, needs {N_MESH * 3}")
    unknown = sorted((set(state.named_neutral) | set(state.ranges)) - set(NAMES))
    if unknown:
        problems.append(f"unknown named features {unknown[:5]}")
    values = [*state.named_neutral.values(), *(v for pair in state.ranges.values() for v in pair)]
    if not finite_within(values) or not all(math.isfinite(v) for v in state.neutral_mesh):
        problems.append(
            f"a named value or range is not a finite number within ±{MAX_VALUE:g}, "
            "or a mesh value is not finite"
        )
    wrong = sorted(name for name, (lo, hi) in state.ranges.items() if not lo < 0 < hi)
    if wrong:
        problems.append(f"ranges {wrong[:5]} need min < 0 < max")
    return problems


# --- files -------------------------------------------------------------------------------------


def parse_state(data: bytes, source: str = "<state>") -> LearnedState:
    """Parse and validate a state file's bytes, or raise :class:`StateError`."""
    try:
        state = msgspec.json.decode(data, type=LearnedState)
    except (msgspec.DecodeError, msgspec.ValidationError, UnicodeDecodeError) as exc:
        raise StateError(f"{source}: {one_line(str(exc))}") from None
    problems = validate_state(state)
    if problems:
        raise StateError(f"{source}: " + "; ".join(problems))
    return state


def load_state(path: Path) -> LearnedState | None:
    """The state kept in ``path`` (``None`` when there is none yet); :class:`StateError` for a
    file that cannot be read or used."""
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise StateError(f"cannot read {path}: {exc}") from None
    return parse_state(data, str(path))


def save_state(path: Path, state: LearnedState) -> None:
    """Write ``state`` to ``path`` atomically (the directory is made if needed)."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(path, msgspec.json.format(msgspec.json.encode(state)))
    except OSError as exc:
        raise StateError(f"cannot write {path}: {exc}") from None
