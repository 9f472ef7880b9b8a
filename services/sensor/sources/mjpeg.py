"""An MJPEG camera URL read as its JPEG parts, each passed on as it is (no decode, no encode).

An ``http(s)://`` camera that answers ``multipart/x-mixed-replace`` (IP cameras, phone camera
apps, ``facesynth simhead``'s ``/camera.mjpg``) already sends JPEGs: the sensor publishes
each part's bytes as the frame, with its size read from the JPEG header
(:func:`~facesynth.runtime.jpeg.jpeg_size`). That saves a decode and an encode per frame.

The reader is blocking (``http.client``), like OpenCV's capture it stands in for, with the
same open and read timeout. A part that is not a JPEG (or whose header cannot be read) is
dropped, counted in :attr:`MjpegStream.dropped` and logged; a stream that stops, times out or
stops being well-formed multipart raises :class:`SourceError`, as a camera that stops
delivering frames does.
"""

from __future__ import annotations

import contextlib
import http.client
import logging
import socket
import ssl
import urllib.parse
from collections.abc import Iterator
from typing import Final

from facesynth.runtime.jpeg import JpegHeaderError, jpeg_size
from facesynth.services.sensor.sources.base import JpegImage, SourceError
from facesynth.services.sensor.sources.multipart import MultipartError, MultipartParser, boundary_of

log = logging.getLogger(__name__)

#: Bytes asked of the socket per read.
CHUNK: Final = 64 * 1024
#: A dropped part is logged the first time and then every this many.
LOG_EVERY: Final = 100


class NotMjpeg(Exception):
    """The URL answers, but not with an MJPEG stream (FFmpeg may still read it)."""


def part_image(body: bytes) -> JpegImage:
    """A part's bytes as a :class:`JpegImage`; :class:`JpegHeaderError` when not a JPEG.

    Line ends or padding some cameras leave after the end-of-image marker are cut off; a JPEG
    without that marker (cut short) is refused.
    """
    width, height = jpeg_size(body)
    body = body.rstrip(b"\r\n\x00")
    if not body.endswith(b"\xff\xd9"):
        raise JpegHeaderError("JPEG cut short (no end-of-image marker)")
    return JpegImage(body, width, height)


class MjpegStream:
    """One open ``multipart/x-mixed-replace`` HTTP response, read part by part."""

    def __init__(self, url: str, timeout_s: float) -> None:
        self.url = url
        self.dropped = 0
        parsed = urllib.parse.urlsplit(url)
        if parsed.scheme.lower() not in ("http", "https") or not parsed.hostname:
            raise NotMjpeg(url)
        path = parsed.path or "/"
        if parsed.query:
            path += "?" + parsed.query
        connection: http.client.HTTPConnection
        if parsed.scheme.lower() == "https":
            context = ssl.create_default_context()
            connection = http.client.HTTPSConnection(
                parsed.hostname, parsed.port, timeout=timeout_s, context=context
            )
        else:
            connection = http.client.HTTPConnection(parsed.hostname, parsed.port, timeout=timeout_s)
        self._connection = connection
        self._socket: socket.socket | None = None
        try:
            connection.request("GET", path, headers={"Accept": "multipart/x-mixed-replace"})
            self._socket = connection.sock  # getresponse() lets go of it ("Connection: close")
            response = connection.getresponse()
        except (OSError, http.client.HTTPException) as exc:
            connection.close()
            raise SourceError(
                f"cannot open the camera stream {url} (nothing streams there?): {exc}"
            ) from None
        if response.status != 200:
            connection.close()
            raise SourceError(
                f"cannot open the camera stream {url} (HTTP {response.status} {response.reason})"
            )
        content_type = response.getheader("Content-Type", "")
        if not content_type.lower().startswith("multipart/"):
            connection.close()
            raise NotMjpeg(content_type)
        try:
            self._parser = MultipartParser(boundary_of(content_type))
        except MultipartError as exc:
            connection.close()
            raise SourceError(f"camera:{url}: not an MJPEG stream: {exc}") from None
        self._response = response

    def images(self) -> Iterator[JpegImage]:
        """Every JPEG part, in order; :class:`SourceError` when the stream stops or breaks."""
        name = f"camera:{self.url}"
        while True:
            try:
                chunk = self._response.read1(CHUNK)
            except (OSError, http.client.HTTPException) as exc:
                raise SourceError(
                    f"{name}: the camera stopped delivering frames ({exc or type(exc).__name__})"
                ) from None
            if not chunk:
                raise SourceError(f"{name}: the camera stopped delivering frames (stream ended)")
            try:
                parts = self._parser.feed(chunk)
            except MultipartError as exc:
                raise SourceError(f"{name}: not an MJPEG stream: {exc}") from None
            for part in parts:
                try:
                    yield part_image(part.body)
                except JpegHeaderError as exc:
                    self.dropped += 1
                    if self.dropped % LOG_EVERY == 1:
                        log.warning(
                            "%s: dropped a part that is not a JPEG (%s; %d dropped so far)",
                            name,
                            exc,
                            self.dropped,
                        )
            if self._parser.ended:
                raise SourceError(f"{name}: the camera stopped delivering frames (stream ended)")

    def close(self) -> None:
        """Close the connection; a read waiting in another thread returns (stream ended)."""
        if self._socket is not None:
            with contextlib.suppress(OSError):
                self._socket.shutdown(socket.SHUT_RDWR)
        self._connection.close()
