"""How bus messages are laid out in MCAP channels, and how the exact bus payloads come back.

For a bus key ``K`` (``facesynth/<rig>/<stage>``; a robot's ``…/servo_commands/<robot>`` or
``…/servo_state/<robot>``, typed as its stage's; or ``facesynth/<rig>/stats/<service>/<id>``):

==================  ==========================================  ===============================
topic               what                                        schema (encoding)
==================  ==========================================  ===============================
``/K``              the message as JSON; a frame without its    the message's JSON Schema from
                    pixels                                      ``schemas/`` (``json``)
``/K/image``        a JPEG frame's pixels                       ``foxglove.CompressedImage``
``/K/image_raw``    a raw (BGR) frame's pixels                  ``foxglove.RawImage`` (protobuf)
``/K/annotations``  the landmarks of a points message           ``foxglove.ImageAnnotations``
``/K/raw``          a payload kept verbatim (see below)         none (``msgpack``)
==================  ==========================================  ===============================

Lossless by construction: a message is stored as JSON (plus its image) only when decoding it
with :mod:`facesynth.runtime.codec` succeeds and re-encoding the decoded struct gives its payload
back byte for byte; msgspec's JSON keeps every float exactly, so the payload is rebuilt from the
JSON (and the image's bytes) exactly. Anything else on the bus (an invalid message, one from a
newer sender with unknown fields) is kept verbatim on ``/K/raw``. Annotations are a view only.
"""

from __future__ import annotations

import collections
import json
from dataclasses import dataclass
from typing import Any, Final

import msgspec

from facesynth.app.recording.views import SchemaSpec, annotations_view, image_view
from facesynth.runtime import codec, keys
from facesynth.schemas.export import message_schema
from facesynth.schemas.messages import (
    BabbleSample,
    Features,
    Frame,
    Points,
    ServiceStats,
    ServoCommands,
)

#: The MCAP profile in the header of every facesynth recording.
PROFILE: Final = "facesynth"
#: Name of the metadata record describing the session (rig, keys, options, version).
METADATA_NAME: Final = "facesynth.session"
#: Version of this layout, in the session metadata.
LAYOUT_VERSION: Final = "1"

MESSAGE: Final = "message"
IMAGE: Final = "image"
ANNOTATIONS: Final = "annotations"
RAW: Final = "raw"
ROLES: Final = (MESSAGE, IMAGE, ANNOTATIONS, RAW)

#: Channel metadata fields naming the bus key and the role of a channel.
KEY_FIELD: Final = "facesynth.key"
ROLE_FIELD: Final = "facesynth.role"

STAGE_TYPES: Final[dict[str, type[Any]]] = {
    "input": Frame,
    "points": Points,
    "features": Features,
    "servo_commands": ServoCommands,
    "servo_state": ServoCommands,
    "babble": BabbleSample,
}
#: The kind of key that carries :class:`ServiceStats` (``…/stats/<service>/<instance>``).
STATS: Final = "stats"


def key_kind(key: str) -> str | None:
    """``input`` … ``servo_state`` (or ``babble``) for a data key, ``stats`` for a stats key,
    else ``None``.

    A robot's key of a multi-robot rig (``…/servo_commands/<robot>``, ``…/servo_state/<robot>``:
    :data:`keys.ROBOT_STAGES`, a valid robot name) is of its stage's kind, like the rig's own."""
    parts = key.split("/")
    if parts[0] != keys.PREFIX:
        return None
    if len(parts) == 3 and parts[2] in STAGE_TYPES:
        return parts[2]
    if keys.robot_of(key) is not None:
        return parts[2]
    if len(parts) == 5 and parts[2] == STATS:
        return STATS
    return None


def message_type(key: str) -> type[Any] | None:
    """The message struct a key carries, or ``None`` for keys facesynth does not define."""
    kind = key_kind(key)
    if kind is None:
        return None
    return ServiceStats if kind == STATS else STAGE_TYPES[kind]


def key_rig(key: str) -> str:
    """The rig of a facesynth key."""
    return key.split("/")[1]


_JSON_SCHEMAS: dict[type[Any], SchemaSpec] = {}


def json_schema(cls: type[Any]) -> SchemaSpec:
    """The JSON Schema channel schema of a message struct."""
    spec = _JSON_SCHEMAS.get(cls)
    if spec is None:
        text = json.dumps(message_schema(cls), sort_keys=True)
        spec = _JSON_SCHEMAS[cls] = SchemaSpec(
            f"facesynth.{cls.__name__}", "jsonschema", text.encode()
        )
    return spec


@dataclass(frozen=True)
class ChannelSpec:
    """One MCAP channel: its topic, the bus key and role behind it, encoding and schema."""

    topic: str
    key: str
    role: str
    message_encoding: str
    schema: SchemaSpec | None

    def metadata(self) -> dict[str, str]:
        """The channel's MCAP metadata (how a reader finds key and role again)."""
        return {KEY_FIELD: self.key, ROLE_FIELD: self.role}


@dataclass(frozen=True, slots=True)
class Entry:
    """One message to write: on ``channel``, at ``log_time`` (receipt, ns since the epoch)."""

    channel: ChannelSpec
    data: bytes
    log_time: int
    publish_time: int
    sequence: int


def topic_of(key: str, role: str) -> str:
    """The MCAP topic of a key's channel with ``role``."""
    return "/" + key if role == MESSAGE else f"/{key}/{role}"


class Layout:
    """Turns bus samples into MCAP entries (see the module docstring for the channels)."""

    def __init__(self, *, annotations: bool = True) -> None:
        self.annotations = annotations
        self._channels: dict[tuple[str, str, SchemaSpec | None], ChannelSpec] = {}
        self._json = msgspec.json.Encoder()
        #: Messages kept verbatim on ``/K/raw``, by key.
        self.raw: collections.Counter[str] = collections.Counter()

    def channel(self, key: str, role: str, schema: SchemaSpec | None) -> ChannelSpec:
        """The (cached) channel of ``key`` with ``role`` and ``schema``."""
        spec = self._channels.get((key, role, schema))
        if spec is None:
            if role == RAW:
                encoding = "msgpack"
            else:
                encoding = (
                    "json" if schema is not None and schema.encoding == "jsonschema" else "protobuf"
                )
            topic = topic_of(key, role)
            if role == IMAGE and schema is not None and schema.name == "foxglove.RawImage":
                topic += "_raw"  # one schema per topic: raw frames have their own
            spec = ChannelSpec(topic, key, role, encoding, schema)
            self._channels[(key, role, schema)] = spec
        return spec

    def entries(self, key: str, payload: bytes, log_time: int, sequence: int) -> list[Entry]:
        """The entries of one bus sample (``sequence`` numbers the samples of one key)."""
        cls = message_type(key)
        message: Any = None
        if cls is not None:
            try:
                message = codec.decode(payload, cls)
            except ValueError:
                message = None
        if cls is None or message is None or not _round_trips(message, payload):
            self.raw[key] += 1
            return [
                Entry(self.channel(key, RAW, None), bytes(payload), log_time, log_time, sequence)
            ]
        publish = int(getattr(message, "t_capture_ns", 0) or getattr(message, "t_ns", log_time))
        entries = []
        if isinstance(message, Frame):
            view = image_view(message)
            meta = msgspec.structs.replace(message, data=b"")
            entries.append(
                self._entry(key, MESSAGE, json_schema(Frame), meta, log_time, publish, sequence)
            )
            if view is not None:
                schema, data = view
                entries.append(
                    Entry(self.channel(key, IMAGE, schema), data, log_time, publish, sequence)
                )
            return entries
        entries.append(
            self._entry(key, MESSAGE, json_schema(cls), message, log_time, publish, sequence)
        )
        if isinstance(message, Points) and self.annotations:
            schema, data = annotations_view(message)
            entries.append(
                Entry(self.channel(key, ANNOTATIONS, schema), data, log_time, publish, sequence)
            )
        return entries

    def _entry(
        self,
        key: str,
        role: str,
        schema: SchemaSpec,
        message: msgspec.Struct,
        log_time: int,
        publish: int,
        sequence: int,
    ) -> Entry:
        return Entry(
            self.channel(key, role, schema), self._json.encode(message), log_time, publish, sequence
        )


def _round_trips(message: msgspec.Struct, payload: bytes) -> bool:
    """Whether the stored form of ``message`` gives ``payload`` back byte for byte."""
    if isinstance(message, Frame) and message.encoding == "none" and message.data:
        return False  # a tick's stray bytes have no image channel to live on
    return codec.encode(message) == bytes(payload)


class RebuildError(ValueError):
    """A stored message that cannot be turned back into a bus payload."""


class Rebuilder:
    """Turns stored channel messages back into the exact bus payloads.

    A frame's JSON and its pixels are two messages with the same sequence number; whichever
    comes first waits (at most ``max_pending`` of them; an orphan is counted in ``orphans``).
    """

    def __init__(self, max_pending: int = 64) -> None:
        self.max_pending = max_pending
        self.orphans = 0
        self._decoders: dict[type[Any], msgspec.json.Decoder[Any]] = {}
        self._frames: collections.OrderedDict[tuple[str, int], Frame] = collections.OrderedDict()
        self._pixels: collections.OrderedDict[tuple[str, int], bytes] = collections.OrderedDict()

    def feed(self, key: str, role: str, data: bytes, sequence: int) -> bytes | None:
        """The bus payload this message completes, if any.

        ``data`` is the stored message; for an ``image`` channel, the image's pixel bytes.
        """
        if role == RAW:
            return bytes(data)
        if role == IMAGE:
            meta = self._frames.pop((key, sequence), None)
            if meta is None:
                self._park(self._pixels, (key, sequence), bytes(data))
                return None
            return codec.encode(msgspec.structs.replace(meta, data=bytes(data)))
        if role != MESSAGE:
            return None
        cls = message_type(key)
        if cls is None:
            raise RebuildError(f"{key}: not a facesynth message key")
        message = self._decode(cls, data, key)
        if isinstance(message, Frame) and message.encoding != "none":
            pixels = self._pixels.pop((key, sequence), None)
            if pixels is None:
                self._park(self._frames, (key, sequence), message)
                return None
            message = msgspec.structs.replace(message, data=pixels)
        return codec.encode(message)

    def _decode(self, cls: type[Any], data: bytes, key: str) -> Any:
        decoder = self._decoders.get(cls)
        if decoder is None:
            decoder = self._decoders[cls] = msgspec.json.Decoder(cls)
        try:
            return decoder.decode(data)
        except (msgspec.DecodeError, msgspec.ValidationError) as exc:
            raise RebuildError(
                f"a message on /{key} is not a valid {cls.__name__}: {exc}"
            ) from None

    def _park(
        self,
        table: collections.OrderedDict[tuple[str, int], Any],
        slot: tuple[str, int],
        value: Any,
    ) -> None:
        table[slot] = value
        while len(table) > self.max_pending:
            table.popitem(last=False)
            self.orphans += 1
