"""Files found by name: profiles (``<name>.toml``) and calibrations (``<name>.json``).

A name is looked up in the folders of an environment variable (``os.pathsep``-separated), then
``~/.config/facesynth/<kind>s``, then any built-in folder; a value with a path separator or the
file suffix is taken as a path.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class NamedFiles:
    """One kind of named file and where to find it."""

    kind: str
    suffix: str
    env_var: str
    builtin: Path | None = None
    #: Whether a missing name's error lists the available names (else the folders searched).
    list_available: bool = False

    def search_dirs(self) -> list[Path]:
        """Folders searched for ``<name><suffix>``, first match wins."""
        dirs: list[Path] = []
        if env := os.environ.get(self.env_var):
            dirs.extend(Path(p) for p in env.split(os.pathsep) if p)
        dirs.append(self.user_dir())
        if self.builtin is not None:
            dirs.append(self.builtin)
        return dirs

    def user_dir(self) -> Path:
        """The user's own folder of this kind, ``~/.config/facesynth/<kind>s``."""
        return Path.home() / ".config" / "facesynth" / f"{self.kind}s"

    def available(self) -> list[str]:
        """Names of every file of this kind in the search folders."""
        dirs = self.search_dirs()
        return sorted({p.stem for d in dirs if d.is_dir() for p in d.glob(f"*{self.suffix}")})

    def resolve(self, name_or_path: str) -> Path:
        """The file a name or path refers to; ``LookupError`` with a clear message otherwise."""
        candidate = Path(name_or_path)
        if candidate.suffix == self.suffix or os.sep in name_or_path:
            if candidate.is_file():
                return candidate
            raise LookupError(f"{self.kind} file {name_or_path} does not exist")
        for folder in self.search_dirs():
            path = folder / f"{name_or_path}{self.suffix}"
            if path.is_file():
                return path
        missing = f"no {self.kind} named {name_or_path!r}"
        if self.list_available:
            raise LookupError(f"{missing} (available: {', '.join(self.available()) or 'none'})")
        raise LookupError(f"{missing} in {', '.join(map(str, self.search_dirs()))}")
