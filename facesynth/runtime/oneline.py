"""User-facing errors are one line: text quoted from a file or a message is escaped."""

from __future__ import annotations


def one_line(text: str) -> str:
    """``text`` with its line breaks escaped (``\\n``, ``\\r``): msgspec and tomllib quote keys
    and values as they are, and a key may hold a newline."""
    return text.replace("\r", "\\r").replace("\n", "\\n")
