"""A ``multipart/x-mixed-replace`` stream cut into its parts, incrementally. Pure Python.

An MJPEG camera (IP cameras, phones, ``facesynth simhead``'s ``/camera.mjpg``) answers one HTTP
request with an endless body: ``--BOUNDARY``, the part's header lines, an empty line, the
part's bytes (one JPEG), and the next boundary. :class:`MultipartParser` takes the body in
chunks of any size (:meth:`~MultipartParser.feed`) and returns the parts completed so far. A
part's end is its ``Content-Length`` when it has one (what cameras send), otherwise the next
boundary line. Anything that is not this shape (no boundary where one must be, a header line
without a colon, a header or a part beyond its size limit, a Content-Length that is not a
number) raises :class:`MultipartError` with a one-line reason: the stream cannot be trusted
from there on.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final

#: The largest part accepted (a 4K JPEG at high quality is a few MB).
MAX_PART_BYTES: Final = 16 * 1024 * 1024
#: The largest header block (or preamble before the first boundary) accepted.
MAX_HEADER_BYTES: Final = 8192


class MultipartError(ValueError):
    """A stream that is not well-formed ``multipart/x-mixed-replace``."""


@dataclass(frozen=True)
class Part:
    """One part: its header fields (names in lower case) and its bytes."""

    headers: dict[str, str]
    body: bytes


def boundary_of(content_type: str) -> str:
    """The boundary named by a ``multipart/x-mixed-replace`` Content-Type header.

    Raises:
        MultipartError: another content type, or no (or an empty) boundary parameter.
    """
    kind, _, params = content_type.partition(";")
    if kind.strip().lower() != "multipart/x-mixed-replace":
        raise MultipartError(f"content type {kind.strip() or '(none)'!r} is not multipart")
    for param in params.split(";"):
        name, _, value = param.partition("=")
        if name.strip().lower() == "boundary":
            value = value.strip().strip('"')
            if value and len(value) <= 200 and value.isascii() and value.isprintable():
                return value
            break
    raise MultipartError("the multipart content type names no usable boundary")


class MultipartParser:
    """Parts of a multipart body fed in chunks; see the module docstring."""

    def __init__(
        self,
        boundary: str,
        *,
        max_part: int = MAX_PART_BYTES,
        max_header: int = MAX_HEADER_BYTES,
    ) -> None:
        # Some cameras put the leading dashes into the boundary parameter too: accept both.
        self._delimiter = b"--" + boundary.removeprefix("--").encode("ascii")
        self._max_part = max_part
        self._max_header = max_header
        self._buffer = bytearray()
        self._state = "boundary"
        self._headers: dict[str, str] = {}
        self._length: int | None = None
        self._scanned = 0  # bytes of a part without a length already searched for a boundary
        self.ended = False

    def feed(self, data: bytes) -> list[Part]:
        """The parts completed by ``data`` (possibly none); :class:`MultipartError` if malformed."""
        if self.ended:
            return []
        self._buffer += data
        parts: list[Part] = []
        while not self.ended:
            step = getattr(self, "_" + self._state)()
            if step is None:
                break
            if isinstance(step, Part):
                parts.append(step)
        return parts

    def _boundary(self) -> bool | None:
        buffer = self._buffer
        # Blank lines (the CRLF ending the previous part) may come before a boundary line.
        start = 0
        while buffer.startswith(b"\r\n", start) or buffer.startswith(b"\n", start):
            start += 2 if buffer[start] == 0x0D else 1
        end = buffer.find(b"\n", start)
        if end < 0:
            if len(buffer) - start > self._max_header:
                raise MultipartError(f"no boundary line in {len(buffer)} bytes")
            return None
        line = bytes(buffer[start:end]).rstrip(b"\r").rstrip(b" \t")
        if line == self._delimiter + b"--":
            self.ended = True
            return None
        if line != self._delimiter:
            shown = line[:40].decode("ascii", "replace")
            raise MultipartError(
                f"expected the boundary {self._delimiter.decode()!r}, got {shown!r}"
            )
        del buffer[: end + 1]
        self._state = "header"
        self._headers = {}
        return True

    def _header(self) -> bool | None:
        buffer = self._buffer
        end = buffer.find(b"\n")
        if end < 0:
            if len(buffer) > self._max_header:
                raise MultipartError(f"a part header line longer than {self._max_header} bytes")
            return None
        line = bytes(buffer[:end]).rstrip(b"\r")
        del buffer[: end + 1]
        if not line:
            self._length = self._content_length()
            self._state = "body"
            return True
        name, colon, value = line.partition(b":")
        if not colon or not name.strip():
            shown = line[:40].decode("ascii", "replace")
            raise MultipartError(f"a part header line without a name: {shown!r}")
        self._headers[name.strip().decode("latin-1").lower()] = value.strip().decode("latin-1")
        if sum(len(k) + len(v) for k, v in self._headers.items()) > self._max_header:
            raise MultipartError(f"part headers longer than {self._max_header} bytes")
        return True

    def _content_length(self) -> int | None:
        text = self._headers.get("content-length")
        if text is None:
            return None
        if not text.isdigit() or not text.isascii():
            raise MultipartError(f"a part's Content-Length {text[:20]!r} is not a number")
        length = int(text)
        if length > self._max_part:
            raise MultipartError(f"a part of {length} bytes (at most {self._max_part})")
        return length

    def _body(self) -> Part | None:
        buffer = self._buffer
        if self._length is not None:
            if len(buffer) < self._length:
                return None
            body = bytes(buffer[: self._length])
            del buffer[: self._length]
        else:
            marker = b"\n" + self._delimiter
            end = buffer.find(marker, max(0, self._scanned - len(marker)))
            if end < 0:
                if len(buffer) > self._max_part:
                    raise MultipartError(f"a part longer than {self._max_part} bytes")
                self._scanned = len(buffer)  # search only the new bytes next time
                return None
            self._scanned = 0
            cut = end - 1 if end > 0 and buffer[end - 1] == 0x0D else end
            body = bytes(buffer[:cut])
            del buffer[: end + 1]
        self._state = "boundary"
        return Part(self._headers, body)
