"""MkDocs hook: a ``|`` inside a code span in a table cell is written ``\\|`` in the pages (so
the table keeps its columns, on GitHub as on the site); GitHub shows it as ``|``, and so does
the site with this hook, where Python-Markdown's tables would keep the backslash."""

from __future__ import annotations

import re
from typing import Any

_CELL = re.compile(r"(<t[dh][^>]*>)(.*?)(</t[dh]>)", re.S)
_CODE = re.compile(r"(<code>)([^<]*)(</code>)")


def unescape_table_pipes(html: str) -> str:
    """``\\|`` inside the code spans of table cells made ``|`` (pure)."""

    def cell(match: re.Match[str]) -> str:
        inner = _CODE.sub(lambda c: c[1] + c[2].replace("\\|", "|") + c[3], match[2])
        return match[1] + inner + match[3]

    return _CELL.sub(cell, html)


def on_page_content(html: str, **_: Any) -> str:
    """MkDocs' hook on each page's HTML."""
    return unescape_table_pipes(html)
