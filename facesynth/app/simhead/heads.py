"""Where a simulated head comes from: a bundled head by name, a head file, or a seed.

:func:`load_head` takes ``simhead16`` (the heads under ``data/heads``), a path to a head file
(:mod:`.config` reads it), or ``seed:N`` / ``generated:N`` (:mod:`.generated` draws it).
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from .config import HeadConfig, HeadError, parse_head
from .generated import generated_head

__all__ = ["head_names", "load_head"]


def _bundled() -> Path:
    return Path(str(resources.files("facesynth.app.simhead") / "data" / "heads"))


def head_names() -> list[str]:
    """The bundled heads' names, sorted."""
    return sorted(p.stem for p in _bundled().glob("*.toml"))


def load_head(name_or_path: str | Path) -> HeadConfig:
    """A bundled head by name (``simhead16``), a head file by path, or a head generated from
    a seed (``seed:N``, :mod:`.generated`)."""
    text = str(name_or_path)
    if text.startswith(("seed:", "generated:")):
        return generated_head(text)
    path = Path(text)
    if not (text.endswith(".toml") or "/" in text or path.exists()):
        bundled = _bundled() / f"{text}.toml"
        if not bundled.is_file():
            raise HeadError(f"unknown head {text!r} (available: {', '.join(head_names())})")
        path = bundled
    if not path.is_file():
        raise HeadError(f"{path}: head file does not exist")
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise HeadError(f"{path}: cannot read ({exc.strerror})") from None
    return parse_head(data, str(path))
