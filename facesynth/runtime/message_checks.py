"""The checks of a facesynth message's values that a type system cannot make.

Every message, decoded from bytes (:func:`facesynth.runtime.codec.decode`) or handed over as an
object within a process (:func:`facesynth.runtime.codec.check`), passes its type's checks here
(:data:`VALIDATORS`): numbers finite and within plausible bounds, counts and lengths bounded,
point sets of whole points of known schemes, no points or features on a "no face" message,
a raw frame of its size and a JPEG whose header agrees with the frame's size. A message that
fails raises :class:`MessageError` naming the first thing wrong with it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from typing import Any

import numpy as np

from facesynth.runtime import blendshapes, limits
from facesynth.runtime.float_lists import float64_array
from facesynth.runtime.jpeg import JpegHeaderError, jpeg_size
from facesynth.schemas.messages import (
    BabbleSample,
    Features,
    Frame,
    Points,
    ServiceStats,
    ServoCommands,
)

#: Largest frame dimension accepted (pixels); larger values are treated as corrupt.
MAX_FRAME_SIDE = limits.MAX_FRAME_SIDE
#: Most pixels a frame may have (width x height).
MAX_FRAME_PIXELS = limits.MAX_FRAME_PIXELS
#: Point schemes and their number of points (a set has at most that many).
SCHEME_POINTS = {"ibug68": 68, "mesh468": 468, "mesh478": 478, "iris10": 10}
#: Points a set of another scheme may hold, sets and score sets a message may hold.
MAX_POINTS = 1024
MAX_SETS = 8
MAX_SCORES = 256
#: Distances (ibug68) and named values a Features message may hold.
MAX_DISTANCES = 68
MAX_NAMED = 256
#: Positions a ServoCommands message may hold (a profile's own count is checked by C).
MAX_POSITIONS = 256
#: Longest sender, host or move name.
MAX_NAME = 256
#: Largest magnitude of a pixel coordinate accepted.
MAX_COORD = 1e6
#: Largest servo pulse width accepted on the wire (µs); anything larger is corrupt.
MAX_PULSE_US = 1e5


class MessageError(ValueError):
    """A message that cannot be used: the reason says what is wrong with it."""


def _finite(value: float, what: str, limit: float = math.inf) -> None:
    if not math.isfinite(value) or abs(value) > limit:
        raise MessageError(f"{what} is {value!r}: must be a finite number within ±{limit:g}")


def _within(array: np.ndarray, limit: float) -> bool:
    """Whether every number of ``array`` is finite and within ``±limit``: one pass for the
    largest magnitude (NaN propagates through the maximum and fails the comparison; an
    infinity fails the second), not four (a third of the time)."""
    peak = np.maximum.reduce(np.abs(array))
    return bool(peak <= limit and peak < math.inf)


#: Lists and tables of up to this many numbers are bounded in a plain loop first
#: (:func:`_small_within`): below about 200 numbers numpy's call costs more than the loop
#: (16 positions: 5.0 → 2.3 µs; 77 named features 5.0 → 2.7 µs). Larger ones, and any that
#: fail the loop, go through numpy, which names the first bad number as before.
SMALL = 200


def _small_within(values: Iterable[Any], low: float, high: float) -> bool:
    """Whether every value is a number within ``low..high`` (NaN and infinities are not; nor
    is anything that does not compare with a number, left to the numpy path to refuse)."""
    try:
        for value in values:
            if not low <= value <= high:
                return False
    except TypeError:
        return False
    return True


def _all_finite(values: list[float], what: str, limit: float) -> None:
    """Check a list of numbers at once (vectorised: a mesh has 1,404 of them)."""
    if not values:
        return
    if len(values) <= SMALL:
        if _small_within(values, -limit, limit):
            return
        # the first bad number named from the loop: numpy's five calls were most of the cost
        # of refusing a flood of NaN points (issue #28)
        for value in values:
            if not isinstance(value, (int, float)):
                break  # not a number: numpy's error, as before
            if not -limit <= value <= limit:
                _finite(float(value), what, limit)
    array = float64_array(values)
    if not _within(array, limit):
        bad = ~np.isfinite(array) | (np.abs(array) > limit)
        _finite(float(array[int(np.argmax(bad))]), what, limit)


def _finite_table(table: dict[str, float], what: str, limit: float) -> None:
    """Check a name → number table at once (vectorised: a Features message has ~170 of them,
    checked by every translator that reads it); the error names the first bad entry."""
    if not table:
        return
    if len(table) <= SMALL and _small_within(table.values(), -limit, limit):
        return
    array = np.fromiter(table.values(), dtype=np.float64, count=len(table))
    if not _within(array, limit):
        bad = ~np.isfinite(array) | (np.abs(array) > limit)
        name = list(table)[int(np.argmax(bad))]
        _finite(table[name], f"{what} {name!r}", limit)


def _common(seq: int, t_capture_ns: int, t_media_ns: int) -> None:
    if seq < 0:
        raise MessageError(f"seq is {seq}: must be >= 0")
    if t_capture_ns < 0 or t_media_ns < 0:
        raise MessageError("timestamps must be >= 0")


def validate_frame(frame: Frame) -> None:
    """Check frame size, encoding and payload length, and a JPEG's size from its header."""
    _common(frame.seq, frame.t_capture_ns, frame.t_media_ns)
    if not (0 < frame.width <= MAX_FRAME_SIDE and 0 < frame.height <= MAX_FRAME_SIDE):
        raise MessageError(f"frame size {frame.width}x{frame.height} is out of range")
    if frame.width * frame.height > MAX_FRAME_PIXELS:
        raise MessageError(
            f"frame size {frame.width}x{frame.height} is over {MAX_FRAME_PIXELS} pixels"
        )
    _finite(frame.fps, "fps", 10_000)
    if frame.encoding == "raw" and len(frame.data) != frame.width * frame.height * 3:
        raise MessageError(
            f"raw frame {frame.width}x{frame.height} needs {frame.width * frame.height * 3} "
            f"bytes, got {len(frame.data)}"
        )
    if frame.encoding == "jpeg":
        if not frame.data.startswith(b"\xff\xd8"):
            raise MessageError("jpeg frame does not start with a JPEG marker")
        try:
            width, height = jpeg_size(frame.data)
        except JpegHeaderError as exc:
            raise MessageError(f"jpeg frame: {exc}") from None
        if (width, height) != (frame.width, frame.height):
            raise MessageError(
                f"jpeg frame is {width}x{height} by its header, but the frame says "
                f"{frame.width}x{frame.height}"
            )


def validate_points(points: Points) -> None:
    """Check confidence, image size and every point set's shape and values."""
    _common(points.seq, points.t_capture_ns, points.t_media_ns)
    _finite(points.confidence, "confidence", 1e6)
    if not (0 < points.image_width <= MAX_FRAME_SIDE and 0 < points.image_height <= MAX_FRAME_SIDE):
        raise MessageError(f"image size {points.image_width}x{points.image_height} is out of range")
    if not points.face and (points.sets or points.scores):
        raise MessageError("a 'no face' message must not carry points or scores")
    if len(points.sets) > MAX_SETS or len(points.scores) > MAX_SETS:
        raise MessageError(
            f"{len(points.sets)} point sets and {len(points.scores)} score sets: "
            f"at most {MAX_SETS} of each"
        )
    seen: set[str] = set()
    for point_set in points.sets:
        if point_set.scheme in seen:
            raise MessageError(f"point set {point_set.scheme!r} appears twice")
        seen.add(point_set.scheme)
        if point_set.dims not in (2, 3):
            raise MessageError(f"point set {point_set.scheme!r} has dims {point_set.dims}")
        if not point_set.coords or len(point_set.coords) % point_set.dims:
            raise MessageError(
                f"point set {point_set.scheme!r} has {len(point_set.coords)} values, "
                f"not a positive multiple of {point_set.dims}"
            )
        count = len(point_set.coords) // point_set.dims
        most = SCHEME_POINTS.get(point_set.scheme, MAX_POINTS)
        if count > most:
            raise MessageError(f"point set {point_set.scheme!r} has {count} points: at most {most}")
        _all_finite(point_set.coords, f"a coordinate of {point_set.scheme!r}", MAX_COORD)
    validate_scores(points)


def validate_scores(points: Points) -> None:
    """Check every score set: unique scheme, finite values; ``blendshapes52``: 52 in [0, 1]."""
    seen: set[str] = set()
    for score_set in points.scores:
        if score_set.scheme in seen:
            raise MessageError(f"score set {score_set.scheme!r} appears twice")
        seen.add(score_set.scheme)
        if not score_set.values:
            raise MessageError(f"score set {score_set.scheme!r} is empty")
        if len(score_set.values) > MAX_SCORES:
            raise MessageError(
                f"score set {score_set.scheme!r} has {len(score_set.values)} values: "
                f"at most {MAX_SCORES}"
            )
        _all_finite(score_set.values, f"a score of {score_set.scheme!r}", MAX_COORD)
        if score_set.scheme == blendshapes.BLENDSHAPES52:
            if len(score_set.values) != blendshapes.COUNT:
                raise MessageError(
                    f"score set 'blendshapes52' has {len(score_set.values)} values, "
                    f"not {blendshapes.COUNT}"
                )
            if _small_within(score_set.values, 0.0, 1.0):
                continue
            array = np.asarray(score_set.values)
            if array.min() < 0.0 or array.max() > 1.0:
                bad = int(np.argmax((array < 0.0) | (array > 1.0)))
                raise MessageError(
                    f"blendshape {blendshapes.NAMES[bad]!r} is {float(array[bad])!r}: "
                    "must be within 0..1"
                )


def validate_features(features: Features) -> None:
    """Check that every feature value is finite and the vectors agree in length."""
    _common(features.seq, features.t_capture_ns, features.t_media_ns)
    if len(features.distances) > MAX_DISTANCES or len(features.displacements) > 2 * MAX_DISTANCES:
        raise MessageError(
            f"{len(features.distances)} distances and {len(features.displacements)} "
            f"displacement values: at most {MAX_DISTANCES} and {2 * MAX_DISTANCES}"
        )
    if len(features.named) > MAX_NAMED or len(features.raw) > MAX_NAMED:
        raise MessageError(
            f"{len(features.named)} named and {len(features.raw)} raw features: "
            f"at most {MAX_NAMED} each"
        )
    if features.deltas and len(features.deltas) != len(features.distances):
        raise MessageError(f"{len(features.deltas)} deltas for {len(features.distances)} distances")
    if not features.face and (
        features.distances or features.deltas or features.named or features.displacements
    ):
        raise MessageError("a 'no face' message must not carry features")
    _all_finite(features.distances, "a distance", MAX_COORD)
    _all_finite(features.deltas, "a delta", MAX_COORD)
    _all_finite(features.displacements, "a displacement", MAX_COORD)
    if features.displacements and len(features.displacements) % 2:
        raise MessageError(f"{len(features.displacements)} displacement values: not x, y pairs")
    for table in (features.named, features.raw):
        _finite_table(table, "feature", MAX_COORD)


def validate_servo_commands(commands: ServoCommands) -> None:
    """Check that every position is a finite, plausible pulse width."""
    _common(commands.seq, commands.t_capture_ns, commands.t_media_ns)
    if not commands.profile:
        raise MessageError("servo commands name no profile")
    if len(commands.positions) > MAX_POSITIONS:
        raise MessageError(
            f"{len(commands.positions)} positions: at most {MAX_POSITIONS} (any profile)"
        )
    if commands.sender_seq < 0 or commands.sent_ns < 0:
        raise MessageError("sender_seq and sent_ns must be >= 0")
    for name in ("profile", "sender", "sender_host", "move"):
        if len(getattr(commands, name)) > MAX_NAME:
            raise MessageError(f"{name} is longer than {MAX_NAME} characters")
    _check_positions(commands.positions)
    _check_readings(commands)


def _check_positions(positions: dict[str, float]) -> None:
    """Every position a finite pulse width within 0..MAX_PULSE_US; the error names the first
    position in order that is not (checked at once, one by one only to name it)."""
    if not positions:
        return
    if len(positions) <= SMALL and _small_within(positions.values(), 0.0, MAX_PULSE_US):
        return
    array = np.fromiter(positions.values(), dtype=np.float64, count=len(positions))
    if _within(array, MAX_PULSE_US) and np.minimum.reduce(array) >= 0:
        return
    for name, value in positions.items():
        _finite(value, f"position of {name!r}", MAX_PULSE_US)
        if value < 0:
            raise MessageError(f"position of {name!r} is negative ({value})")


def _check_readings(commands: ServoCommands) -> None:
    """The read-back tables of ``…/servo_state``: at most one entry per possible servo, finite
    numbers (loads within ±1, temperatures within ±1000 °C) and one-line faults."""
    for what, table, limit in (
        ("measured position", commands.measured, MAX_PULSE_US),
        ("load", commands.loads, 1.0),
        ("temperature", commands.temperatures_c, 1000.0),
    ):
        if len(table) > MAX_POSITIONS:
            raise MessageError(f"{len(table)} {what}s: at most {MAX_POSITIONS}")
        _finite_table(table, what, limit)
    if len(commands.faults) > MAX_POSITIONS:
        raise MessageError(f"{len(commands.faults)} faults: at most {MAX_POSITIONS}")
    for name, fault in commands.faults.items():
        if len(fault) > MAX_NAME or "\n" in fault:
            raise MessageError(f"the fault of {name!r} is not one line of {MAX_NAME} characters")


def validate_stats(stats: ServiceStats) -> None:
    """Check the figures of a stats message are finite and the counts not negative."""
    for name in ("uptime_s", "rate_hz", "rss_mb", "peak_rss_mb"):
        _finite(getattr(stats, name), name)
    for name in ("latency_p50_ms", "latency_p99_ms"):
        value = getattr(stats, name)
        if value is not None:
            _finite(value, name)
    for name in ("received", "published", "dropped", "rejected", "window"):
        if getattr(stats, name) < 0:
            raise MessageError(f"{name} is {getattr(stats, name)}: must be >= 0")


def validate_babble_sample(sample: BabbleSample) -> None:
    """Check a settled pose: plausible pulse widths, finite features, sane counts and names."""
    _common(sample.seq, sample.t_capture_ns, sample.t_media_ns)
    if not sample.profile:
        raise MessageError("a babbling sample names no profile")
    for name in ("profile", "kind"):
        if len(getattr(sample, name)) > MAX_NAME:
            raise MessageError(f"{name} is longer than {MAX_NAME} characters")
    if sample.frames < 0:
        raise MessageError(f"frames is {sample.frames}: must be >= 0")
    if len(sample.reached) > MAX_NAME:
        raise MessageError(f"reached is longer than {MAX_NAME} characters")
    for what, positions in (
        ("commanded", sample.commanded),
        ("reported", sample.reported),
        ("measured", sample.measured),
    ):
        if len(positions) > MAX_POSITIONS:
            raise MessageError(f"{len(positions)} {what} positions: at most {MAX_POSITIONS}")
        _finite_table(positions, f"{what} position", MAX_PULSE_US)
        for name, value in positions.items():
            if value < 0:
                raise MessageError(f"{what} position of {name!r} is negative ({value})")
    for what, table in (("feature", sample.features), ("spread of", sample.spread)):
        if len(table) > MAX_NAMED:
            raise MessageError(f"{len(table)} {what} values: at most {MAX_NAMED}")
        _finite_table(table, what, MAX_COORD)


#: Each message type's checks, by class (:func:`facesynth.runtime.codec.decode` and
#: :func:`facesynth.runtime.codec.check` run them).
VALIDATORS: dict[type[Any], Callable[[Any], None]] = {
    Frame: validate_frame,
    Points: validate_points,
    Features: validate_features,
    ServoCommands: validate_servo_commands,
    ServiceStats: validate_stats,
    BabbleSample: validate_babble_sample,
}
