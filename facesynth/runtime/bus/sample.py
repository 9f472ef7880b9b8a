"""What a mailbox holds: a received :class:`Sample`, and the :class:`Parcel` of a message
published within a process (the object itself, its bytes encoded at most once, when first
asked for)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

__all__ = ["Parcel", "Sample"]


class Parcel:
    """A message published within a process: the object, and its bytes encoded when first
    asked for (at most once, however many readers ask)."""

    __slots__ = ("_encode", "_payload", "message")

    def __init__(self, message: Any, encode: Callable[[Any], bytes]) -> None:
        self.message = message
        self._encode = encode
        self._payload: bytes | None = None

    def payload(self) -> bytes:
        """The message's bytes, encoded on the first call."""
        if self._payload is None:
            self._payload = self._encode(self.message)
        return self._payload


class Sample:
    """One received message: the key it was published on, when it arrived, its bytes and,
    where a screen decoded them or the mailbox took a message published in this process,
    its ``message`` (``None`` otherwise).

    A sample of a message published in this process holds its :class:`Parcel` (``parcel``):
    ``payload`` is then encoded on first use (once for every reader of that publication)."""

    __slots__ = ("_data", "key", "message", "t_received_ns")

    def __init__(
        self, key: str, payload: bytes | Parcel, t_received_ns: int, message: Any = None
    ) -> None:
        self.key = key
        self._data = payload
        self.t_received_ns = t_received_ns
        self.message = message

    @property
    def payload(self) -> bytes:
        """The message's bytes (encoded now for an in-process message not encoded before)."""
        data = self._data
        return data.payload() if isinstance(data, Parcel) else data

    @property
    def parcel(self) -> Parcel | None:
        """The in-process publication this sample carries, or ``None`` (bytes from a transport)."""
        data = self._data
        return data if isinstance(data, Parcel) else None

    def __repr__(self) -> str:
        what = "parcel" if self.parcel is not None else f"{len(self.payload)} bytes"
        return f"Sample({self.key!r}, {what}, {self.t_received_ns}, {self.message!r})"
