"""The documentation site builds strictly (issue 28): ``mkdocs build --strict`` over docs/ and
mkdocs.yml, as ``make docs`` runs it. Strict, a broken link or anchor, a page left out of the nav
or a missing included file (ARCHITECTURE.md, which the Architecture page includes) fails the
build; copies of the site with each of these faults show that it does."""

from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


def build(project: Path, site: Path) -> subprocess.CompletedProcess[str]:
    """``mkdocs build --strict`` of ``project``'s mkdocs.yml into ``site``."""
    config = ["--config-file", str(project / "mkdocs.yml"), "--site-dir", str(site)]
    return subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", *config],
        capture_output=True,
        text=True,
        timeout=180,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
    )


def copy_of_the_site(where: Path) -> Path:
    """mkdocs.yml, docs/ and ARCHITECTURE.md copied into ``where``."""
    where.mkdir(parents=True)
    shutil.copy(ROOT / "mkdocs.yml", where / "mkdocs.yml")
    shutil.copy(ROOT / "ARCHITECTURE.md", where / "ARCHITECTURE.md")
    shutil.copytree(DOCS, where / "docs", ignore=shutil.ignore_patterns("__pycache__"))
    return where


def test_the_site_builds_strictly(tmp_path: Path) -> None:
    done = build(ROOT, tmp_path / "site")
    assert done.returncode == 0, done.stdout + done.stderr
    pages = sorted(DOCS.glob("*.md"))
    assert len(pages) >= 10
    for page in pages:
        built = tmp_path / "site" / ("" if page.stem == "index" else page.stem) / "index.html"
        assert built.is_file(), page.name
    architecture = (tmp_path / "site" / "architecture" / "index.html").read_text("utf-8")
    assert "Where to add things" in architecture  # ARCHITECTURE.md, included
    assert "--8&lt;--" not in architecture and "--8<--" not in architecture
    assert (tmp_path / "site" / "side-by-side.png").is_file()  # the README's pictures too
    assert not (tmp_path / "site" / "readme_media.py").exists()  # the script is not published
    assert not (tmp_path / "site" / "hooks").exists()
    running = (tmp_path / "site" / "running" / "index.html").read_text("utf-8")
    # a table's `A \| B` shows as on GitHub (docs/hooks/table_pipes.py)
    assert "<code>facesynth sensor --video V | --camera N | --images DIR</code>" in running
    assert "\\|" not in running


def test_table_pipes_unescapes_code_in_table_cells_only() -> None:
    spec = importlib.util.spec_from_file_location("table_pipes", DOCS / "hooks" / "table_pipes.py")
    assert spec is not None and spec.loader is not None
    hook = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hook)
    html = (
        "<table><tr><td><code>a \\| b</code> c \\| d</td><th><code>e\\|f</code></th></tr></table>"
        "<p><code>g \\| h</code></p><pre><code>i \\| j</code></pre>"
    )
    assert hook.unescape_table_pipes(html) == (
        "<table><tr><td><code>a | b</code> c \\| d</td><th><code>e|f</code></th></tr></table>"
        "<p><code>g \\| h</code></p><pre><code>i \\| j</code></pre>"
    )


def test_a_broken_link_an_unknown_anchor_and_a_page_outside_the_nav_fail_it(
    tmp_path: Path,
) -> None:
    project = copy_of_the_site(tmp_path / "project")
    safety = project / "docs" / "safety.md"
    safety.write_text(
        safety.read_text("utf-8")
        + "\nSee [nothing](nosuch.md) and [no heading](running.md#no-such-heading).\n",
        "utf-8",
    )
    (project / "docs" / "stray.md").write_text("# A page no nav lists\n", "utf-8")
    done = build(project, tmp_path / "site")
    out = done.stdout + done.stderr
    assert done.returncode != 0, out
    assert "'nosuch.md'" in out
    assert "'#no-such-heading'" in out
    assert "stray.md" in out


def test_a_missing_included_file_fails_it(tmp_path: Path) -> None:
    project = copy_of_the_site(tmp_path / "project")
    (project / "ARCHITECTURE.md").unlink()
    done = build(project, tmp_path / "site")
    assert done.returncode != 0, done.stdout + done.stderr
    assert "ARCHITECTURE.md" in done.stdout + done.stderr


def test_the_built_site_is_ignored() -> None:
    assert "/site/" in (ROOT / ".gitignore").read_text("utf-8").split()
