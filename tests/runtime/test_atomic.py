"""runtime.atomic: a reader sees the old file or the new one, never half of either."""

from __future__ import annotations

from pathlib import Path

import pytest

from facesynth.runtime import atomic
from facesynth.runtime.atomic import open_atomic


def _leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".tmp"))


def test_failed_atomic_write_keeps_the_old_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    target = tmp_path / "data.bin"
    atomic.write_atomic(target, b"old")

    def broken_replace(src: str, dst: str) -> None:
        raise OSError("disk full")

    monkeypatch.setattr(atomic.os, "replace", broken_replace)
    with pytest.raises(OSError, match="disk full"):
        atomic.write_atomic(target, b"new contents")
    assert target.read_bytes() == b"old"
    assert _leftovers(tmp_path) == []


def test_write_atomic_text_and_bytes(tmp_path: Path) -> None:
    assert atomic.write_atomic(tmp_path / "a" / "b.txt", "héllo").read_bytes() == "héllo".encode()
    assert atomic.write_atomic(tmp_path / "c.bin", b"\x00\xff").read_bytes() == b"\x00\xff"
    assert _leftovers(tmp_path) == []


def test_open_atomic_replaces_the_file_when_the_block_ends(tmp_path: Path) -> None:
    target = tmp_path / "sub" / "lines.jsonl"
    with open_atomic(target) as handle:
        handle.write(b"one\n")
        assert not target.exists()  # nothing visible before the block ends
        handle.write(b"two\n")
    assert target.read_bytes() == b"one\ntwo\n"
    assert _leftovers(target.parent) == []


def test_an_error_in_the_block_keeps_the_old_file(tmp_path: Path) -> None:
    target = tmp_path / "lines.jsonl"
    target.write_bytes(b"previous\n")
    with pytest.raises(RuntimeError, match="decoder died"), open_atomic(target) as handle:
        handle.write(b"half of the new ")
        raise RuntimeError("decoder died")
    assert target.read_bytes() == b"previous\n"
    assert _leftovers(tmp_path) == []


def test_an_interrupt_in_the_block_keeps_the_old_file(tmp_path: Path) -> None:
    target = tmp_path / "lines.jsonl"
    target.write_bytes(b"previous\n")
    with pytest.raises(KeyboardInterrupt), open_atomic(target) as handle:
        handle.write(b"half")
        raise KeyboardInterrupt
    assert target.read_bytes() == b"previous\n"
    assert _leftovers(tmp_path) == []
