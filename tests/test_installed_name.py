"""One installed name: the wheel's only top-level package is ``facesynth``.

``services/`` and ``schemas/`` stay top-level folders of the repository; ``facesynth/services``
and ``facesynth/schemas`` are links to them, so they install (and import) as
``facesynth.services`` and ``facesynth.schemas``, and a user project with its own ``services``
package neither shadows ours nor is shadowed by it.
"""

from __future__ import annotations

import ast
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SOURCE_FOLDERS = ("facesynth", "services", "schemas", "tests", "tools")


def _tracked_files() -> list[str]:
    listed = subprocess.run(
        ["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True, timeout=60
    )
    return [name for name in listed.stdout.decode().split("\0") if name]


@pytest.fixture(scope="module")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> zipfile.ZipFile:
    """The wheel built from the tracked files only (a copy: no stale ``build/`` of this tree)."""
    source = tmp_path_factory.mktemp("source")
    for name in _tracked_files():
        origin, copy = ROOT / name, source / name
        if not origin.is_symlink() and not origin.is_file():
            continue  # deleted in the working tree, not yet committed
        copy.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(origin, copy, follow_symlinks=False)
    out = tmp_path_factory.mktemp("wheel")
    built = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(out), str(source)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert built.returncode == 0, built.stdout + built.stderr
    (path,) = out.glob("facesynth-*.whl")
    return zipfile.ZipFile(path)


def test_the_wheel_installs_one_top_level_name(wheel: zipfile.ZipFile) -> None:
    tops = {name.split("/")[0] for name in wheel.namelist()}
    dist_info = {top for top in tops if top.endswith(".dist-info")}
    assert tops - dist_info == {"facesynth"}, sorted(tops)
    top_level = [n for n in wheel.namelist() if n.endswith(".dist-info/top_level.txt")]
    for name in top_level:
        assert wheel.read(name).decode().split() == ["facesynth"]


def test_the_stages_and_their_files_install_under_facesynth(wheel: zipfile.ZipFile) -> None:
    names = set(wheel.namelist())
    for expected in (
        "facesynth/services/translator/core.py",
        "facesynth/services/control/drivers/virtual/static/face.js",
        "facesynth/services/points/tracker/models/face_landmark.tflite",
        "facesynth/schemas/messages.py",
        "facesynth/schemas/facesynth.schema.json",
    ):
        assert expected in names, expected


def test_the_repository_keeps_services_and_schemas_at_the_top() -> None:
    for name in ("services", "schemas"):
        assert (ROOT / name).is_dir() and not (ROOT / name).is_symlink()
        link = ROOT / "facesynth" / name
        assert link.is_symlink() and link.resolve() == (ROOT / name).resolve(), link


def _top_level_imports(path: Path) -> list[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    found: list[str] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.append(node.module)
    return found


def test_no_module_imports_services_or_schemas_by_their_old_top_level_names() -> None:
    """Run from the repository's root, ``import services`` would still work (the folder is on
    sys.path) and load a second copy of every stage next to ``facesynth.services``."""
    wrong = [
        f"{path.relative_to(ROOT)}: {name}"
        for folder in SOURCE_FOLDERS
        for path in sorted((ROOT / folder).rglob("*.py"))
        if "facesynth/services" not in path.as_posix()
        and "facesynth/schemas" not in path.as_posix()
        for name in _top_level_imports(path)
        if name.split(".")[0] in {"services", "schemas"}
    ]
    assert not wrong, wrong


def test_the_guard_sees_an_old_import(tmp_path: Path) -> None:
    module = tmp_path / "old.py"
    module.write_text("from services.translator.core import Translator\nimport schemas.keys\n")
    assert _top_level_imports(module) == ["services.translator.core", "schemas.keys"]
