"""A JPEG's pixel dimensions from its frame header (SOF), without decoding it. Pure Python.

A 4 MB JPEG declaring 16000x16000 pixels once stopped a chain for 4 s while OpenCV decoded it.
:func:`jpeg_size` walks the marker segments from the start of image (each names its length)
to the first start-of-frame marker and reads its height and width; the codec compares them with
the frame's declared size and the largest frame allowed before anything decodes the pixels.
The walk reads a few bytes per segment header, so even a hostile file costs microseconds.
"""

from __future__ import annotations

#: Start-of-frame markers (baseline, extended, progressive, lossless; Huffman or arithmetic).
SOF_MARKERS = frozenset(
    {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}
)
#: Markers without a length field (TEM and the restart markers).
STANDALONE = frozenset({0x01, *range(0xD0, 0xD8)})


class JpegHeaderError(ValueError):
    """JPEG bytes whose frame header cannot be found or read."""


def jpeg_size(data: bytes | bytearray | memoryview) -> tuple[int, int]:
    """``(width, height)`` of a JPEG, from its first start-of-frame segment.

    Raises :class:`JpegHeaderError` for bytes that are not a JPEG, a header cut short, a scan
    or end of image before any frame header, or a frame header that puts its height in a later
    DNL segment (height 0; no camera or encoder here makes one).
    """
    view = memoryview(data)
    size = len(view)
    if size < 4 or view[0] != 0xFF or view[1] != 0xD8:
        raise JpegHeaderError("not a JPEG (no start-of-image marker)")
    i = 2
    while i < size:
        if view[i] != 0xFF:
            raise JpegHeaderError(f"no JPEG marker at byte {i}")
        while i < size and view[i] == 0xFF:  # fill bytes may precede a marker
            i += 1
        if i >= size:
            break
        marker = view[i]
        i += 1
        if marker in STANDALONE:
            continue
        if marker in (0xD8, 0xD9, 0xDA):  # SOI again, EOI or a scan: no frame header before
            raise JpegHeaderError(f"no frame header before marker 0xFF{marker:02X}")
        if i + 2 > size:
            break
        length = (view[i] << 8) | view[i + 1]
        if length < 2:
            raise JpegHeaderError(f"marker 0xFF{marker:02X} has a length of {length}")
        if marker in SOF_MARKERS:
            if length < 8 or i + 7 > size:
                break
            height = (view[i + 3] << 8) | view[i + 4]
            width = (view[i + 5] << 8) | view[i + 6]
            if height == 0 or width == 0:
                raise JpegHeaderError(f"frame header declares {width}x{height} pixels")
            return width, height
        i += length
    raise JpegHeaderError("JPEG header cut short before its frame header")
