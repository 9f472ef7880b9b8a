"""Files in and out of recordings: OpenFace CSV and ``facesynth track`` files to MCAP; a
recording's commands to the record driver's JSON lines, or CSV for spreadsheets.

Imported landmarks go through the same replay backends as ``facesynth points
--openface-csv/--points-jsonl`` (frame ``n`` of a ``fps`` clock, at the sensor's nominal image
size for frames without pixels), so replaying the converted file ``--from points`` gives the
same commands as running the chain on the original file. A converted file has no wall clock:
capture and receipt times are the media time.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import msgspec

from facesynth.app.recording.layout import LAYOUT_VERSION, Layout
from facesynth.app.recording.reader import Recording
from facesynth.app.recording.writer import SessionWriter
from facesynth.runtime import codec, keys
from facesynth.runtime.atomic import open_atomic
from facesynth.runtime.feature_names import NAMES
from facesynth.runtime.frames import TICK_SIZE
from facesynth.schemas.messages import Frame, ServoCommands
from facesynth.services.control.drivers.record import RecordLine
from facesynth.services.points.backends import PointsBackend
from facesynth.services.points.backends.openface import OpenFaceConfig, OpenFaceReplay
from facesynth.services.points.backends.track import TrackFileConfig, TrackReplay

#: What ``convert`` can export, and from which stages.
EXPORT_STAGES = ("servo_state", "servo_commands", "features")


class ConvertError(ValueError):
    """A conversion that cannot be made (unknown file kind, nothing to export)."""


def parse_size(text: str) -> tuple[int, int]:
    """``WIDTHxHEIGHT``, e.g. ``640x480``."""
    try:
        width, height = (int(part) for part in text.lower().split("x"))
    except ValueError:
        raise ConvertError(f"bad image size {text!r}: use WIDTHxHEIGHT, e.g. 640x480") from None
    if not (0 < width <= codec.MAX_FRAME_SIDE and 0 < height <= codec.MAX_FRAME_SIDE):
        raise ConvertError(f"image size {width}x{height} is out of range")
    return width, height


def landmarks_backend(path: Path) -> PointsBackend:
    """The replay backend for an OpenFace CSV (``.csv``) or a track file (``.jsonl``)."""
    if path.suffix.lower() == ".csv":
        return OpenFaceReplay(OpenFaceConfig(csv=str(path)))
    if path.suffix.lower() in (".jsonl", ".json"):
        return TrackReplay(TrackFileConfig(path=str(path)))
    raise ConvertError(f"{path}: convert reads OpenFace .csv or facesynth track .jsonl files")


def landmarks_to_mcap(
    source: str | Path,
    out: str | Path,
    *,
    rig: str = "default",
    fps: float = 30.0,
    size: tuple[int, int] = TICK_SIZE,
    overwrite: bool = False,
) -> int:
    """Write the landmarks of ``source`` as a recording of ``…/points``; return the count."""
    if not 0 < fps <= 1000:
        raise ConvertError("--fps must be within 0..1000")
    path = Path(source)
    backend = landmarks_backend(path)
    count = backend.frame_count() or 0
    key = keys.stage_key(rig, "points")
    metadata = {
        "rig": rig,
        "keys": "points",
        "source": f"{backend.name}:{path.name}",
        "fps": f"{fps:g}",
        "layout": LAYOUT_VERSION,
    }
    writer = SessionWriter(out, metadata=metadata, fsync=False, overwrite=overwrite)
    layout = Layout()
    try:
        for seq in range(count):
            t_media = round(seq * 1e9 / fps)
            tick = Frame(
                seq=seq,
                t_capture_ns=t_media,
                t_media_ns=t_media,
                width=size[0],
                height=size[1],
                encoding="none",
                source=backend.name,
                fps=fps,
            )
            for entry in layout.entries(key, codec.encode(backend.process(tick)), t_media, seq):
                writer.write(entry)
    finally:
        writer.close()
    return count


def _export_source(recording: Recording, stage: str | None) -> str:
    stages = recording.stages()
    if stage is None:
        for candidate in ("servo_state", "servo_commands"):
            if candidate in stages:
                return candidate
        raise ConvertError(
            f"{recording.path} holds no servo commands to export "
            f"(it has: {', '.join(stages) or 'none'})"
        )
    if stage not in EXPORT_STAGES:
        raise ConvertError(f"--stage must be one of {', '.join(EXPORT_STAGES)}")
    if stage not in stages:
        raise ConvertError(
            f"{recording.path} holds no {stage} messages (it has: {', '.join(stages) or 'none'})"
        )
    return stage


def export_keys(recording: Recording, stage: str, robot: str | None = None) -> list[str]:
    """The recorded keys an export of ``stage`` takes: the stage's one key, or, from a
    multi-robot rig's recording (``…/servo_state/a``, ``…/servo_state/b``), ``robot``'s."""
    found = recording.stage_keys(stage)
    if robot is not None:
        keys.check_name(robot, "robot")
        chosen = [key for key in found if keys.robot_of(key) == robot]
        if not chosen:
            raise ConvertError(
                f"{recording.path} holds no {stage} of robot {robot!r} "
                f"(it has: {', '.join(found) or 'none'})"
            )
        return chosen
    if len(found) > 1:
        raise ConvertError(
            f"{recording.path} holds the {stage} of several robots ({', '.join(found)}): "
            "give --robot NAME"
        )
    return found


def _messages(recording: Recording, sources: list[str]) -> Iterator[tuple[Any, int]]:
    """The messages of ``sources`` (:func:`export_keys`); of servo state only the commands
    applied (a controller's own moves, ``move`` other than ``"command"``, are in the
    recording, not in an export by frame).
    """
    for _, message, log_time in recording.messages(sources):
        if isinstance(message, ServoCommands) and message.move != "command":
            continue
        yield message, log_time


def export_jsonl(
    recording: Recording, out: str | Path, stage: str | None = None, robot: str | None = None
) -> int:
    """The commands (``robot``'s, see :func:`export_keys`) as the record driver's JSON lines
    (``t_sent_ns`` = when they were seen)."""
    chosen = _export_source(recording, stage)
    sources = export_keys(recording, chosen, robot)
    if chosen == "features":
        raise ConvertError("JSON lines hold servo commands: use a .csv output for features")
    encoder = msgspec.json.Encoder()
    count = 0
    with open_atomic(out) as handle:
        for message, log_time in _messages(recording, sources):
            assert isinstance(message, ServoCommands)
            line = RecordLine(
                seq=count,
                frame=message.seq,
                t_capture_ns=message.t_capture_ns,
                t_sent_ns=log_time,
                face=message.face,
                servos={name: round(value, 3) for name, value in message.positions.items()},
            )
            handle.write(encoder.encode(line) + b"\n")
            count += 1
    return count


def export_csv(
    recording: Recording, out: str | Path, stage: str | None = None, robot: str | None = None
) -> int:
    """One row per message: frame, times, face, then one column per servo (or named feature);
    ``robot``'s commands from a multi-robot rig's recording (see :func:`export_keys`)."""
    chosen = _export_source(recording, stage)
    sources = export_keys(recording, chosen, robot)
    columns: list[str] | None = None
    count = 0
    with open_atomic(out) as handle:
        text = io.TextIOWrapper(handle, encoding="utf-8", newline="")
        writer = csv.writer(text)
        for message, log_time in _messages(recording, sources):
            values = message.positions if isinstance(message, ServoCommands) else message.named
            if columns is None:
                columns = list(values) if isinstance(message, ServoCommands) else list(NAMES)
                writer.writerow(
                    ["frame", "t_media_s", "t_capture_ns", "t_log_ns", "face", *columns]
                )
            row = [
                message.seq,
                f"{message.t_media_ns / 1e9:.6f}",
                message.t_capture_ns,
                log_time,
                int(message.face),
            ]
            writer.writerow(row + [_cell(values.get(name)) for name in columns])
            count += 1
        text.flush()
        text.detach()
    return count


def _cell(value: float | None) -> str:
    return "" if value is None else repr(round(value, 6))
