"""The README and the documentation agree with the program (issues 20 and 28): their commands,
paths, links and Python names exist.

Read from whatever README.md, ARCHITECTURE.md and every page of docs/ hold, so text added later
(and a page added later) is checked too:

* every ``facesynth …`` command line, in a code block (a line starting with ``facesynth ``,
  with its ``\\`` continuations) or in backticks, names a sub-command of the real parser, and
  every ``--flag`` on it is one of that sub-command's options (``--help`` level: values,
  placeholders such as ``[GRAPH]``, ``…`` and ``A | B`` alternatives are not parsed);
* every repository path in backticks (``facesynth/app/graphs/demo.toml``, ``ARCHITECTURE.md``)
  exists; placeholders (``NAME``, ``<rig>``, ``…``) are skipped;
* every Markdown link to a file (``docs/side-by-side.png`` from the README, ``running.md`` from a
  page of docs/) exists beside the page that links it, and a ``#fragment`` on a link to a page is
  one of that page's headings (``mkdocs build --strict``, tests/test_docs_site.py, checks the
  site's own links too);
* every dotted Python name of the project in backticks (``facesynth.runtime.rig_view.RigView``)
  imports, or is a logger name or a plugin entry-point group the code uses (``facesynth.link``,
  ``facesynth.drivers``).
"""

from __future__ import annotations

import argparse
import importlib
import re
import unicodedata
from fnmatch import fnmatch
from functools import cache
from pathlib import Path

import pytest

from facesynth.app.cli import build_parser

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DOCS = ROOT / "docs"
#: Top-level folders of the repository: a backticked ``dir/…`` path in one of them must exist.
TOP_DIRS = ("facesynth", "services", "schemas", "tests", "deploy", "docs", "tools", "firmware")
PACKAGES = ("facesynth", "services", "schemas")
STAGES = ("sensor", "points", "features", "translator", "control")

_FENCE = re.compile(r"^\s*```")
_TICKS = re.compile(r"`([^`\n]+)`")
_LINK = re.compile(r"\]\(([^)\s]+)\)")
_FLAG = re.compile(r"(?<![\w-])(--[a-z][a-z0-9-]*)")
_PATH = re.compile(
    rf"^(?:(?:{'|'.join(TOP_DIRS)})/[\w./-]*|[\w-]+\.(?:md|toml|yml|yaml|cfg|txt)|LICENSE|Makefile|"
    r"Dockerfile)$"
)
_DOTTED = re.compile(rf"^(?:{'|'.join(PACKAGES)})(?:\.\w+)+$")
_PLACEHOLDER = re.compile(r"[<>…*{}\[\]]")
#: An upper-case word in a path that does not exist is a placeholder (``NAME.toml``).
_CAPS = re.compile(r"[A-Z]{2,}")


def readme_text() -> str:
    return README.read_text(encoding="utf-8")


def documents() -> list[Path]:
    """The README, ARCHITECTURE.md (the site's Architecture page includes it) and every page of
    docs/."""
    return [README, ROOT / "ARCHITECTURE.md", *sorted(DOCS.rglob("*.md"))]


def page_text(page: Path) -> str:
    """A page as the site shows it: ``--8<-- "FILE"`` lines (pymdownx.snippets) replaced by the
    repository file they include."""
    text = page.read_text(encoding="utf-8")
    return re.sub(
        r'^--8<-- "([^"]+)"$',
        lambda m: (ROOT / m.group(1)).read_text(encoding="utf-8"),
        text,
        flags=re.M,
    )


def _code_and_prose(text: str) -> tuple[list[str], list[str]]:
    """The README's lines inside fenced code blocks, and the others."""
    code: list[str] = []
    prose: list[str] = []
    inside = False
    for line in text.splitlines():
        if _FENCE.match(line):
            inside = not inside
            continue
        (code if inside else prose).append(line)
    return code, prose


def command_lines(text: str) -> list[str]:
    """Every ``facesynth …`` command of the README, continuations joined, comments dropped."""
    code, prose = _code_and_prose(text)
    commands: list[str] = []
    pending: str | None = None
    for line in code:
        stripped = line.strip()
        if pending is not None:
            pending += " " + stripped
        elif stripped.startswith("facesynth "):
            pending = stripped
        else:
            continue
        if pending.endswith("\\"):
            pending = pending[:-1]
            continue
        commands.extend(" ".join(part.split()) for part in pending.split(";"))
        pending = None
    # inline: `facesynth …` in prose (a span may be cut by a line break: joined per paragraph)
    for paragraph in "\n".join(prose).split("\n\n"):
        for span in _TICKS.findall(paragraph.replace("\n", " ")):
            if span.startswith("facesynth "):
                commands.append(" ".join(span.split()))
    out = []
    for command in commands:
        command = re.split(r"\s#", command)[0]  # a trailing comment
        command = re.split(r"\s(?:&&|&|\|\||>)\s?", command)[0]  # a shell's next command
        words = command.split()
        if command.startswith("facesynth ") and not words[1].endswith(":"):  # not an error line
            out.append(command.strip())
    return out


@cache
def _parser() -> argparse.ArgumentParser:
    return build_parser()


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def command_problem(command: str) -> str | None:
    """Why a README command would not parse (its sub-command or a flag is unknown), or None."""
    words = command.split()
    subs = _subparsers(_parser())
    if len(words) < 2:
        return "no sub-command"
    name = words[1]
    if name == "STAGE":  # `facesynth STAGE …`: each stage's sub-command
        problems = [command_problem(command.replace("STAGE", stage, 1)) for stage in STAGES]
        return next((p for p in problems if p), None)
    if name.startswith("-"):
        flags = set(_parser()._option_string_actions)
        unknown = [f for f in _FLAG.findall(command) if f not in flags]
        return f"unknown option {unknown[0]}" if unknown else None
    if name not in subs:
        return f"no sub-command {name!r} (has: {', '.join(sorted(subs))})"
    flags = set(subs[name]._option_string_actions)
    for flag in _FLAG.findall(" ".join(words[2:])):
        if flag not in flags:
            return f"facesynth {name} has no option {flag}"
    return None


def _ignored(path: str) -> bool:
    """Whether git ignores ``path`` (a file the README asks the user to put there) while its
    folder exists."""
    patterns = (ROOT / ".gitignore").read_text("utf-8").split()
    anchored = [p[1:] for p in patterns if p.startswith("/")]
    return (ROOT / path).parent.is_dir() and any(fnmatch(path, p) for p in anchored)


def named_paths(text: str) -> list[str]:
    """Repository paths a page names in backticks (no placeholders)."""
    paths = []
    for span in _TICKS.findall(text):
        span = span.strip().rstrip(".,;:")
        if span.startswith(("http:", "https:", "#")) or _PLACEHOLDER.search(span):
            continue
        if _PATH.match(span) and not (_CAPS.search(span) and not (ROOT / span).exists()):
            paths.append(span)
    return paths


def linked_targets(text: str) -> list[str]:
    """The targets of a page's Markdown links and images (web addresses left out)."""
    return [t for t in _LINK.findall(text) if not re.match(r"^[a-z][a-z0-9+.-]*:", t)]


def heading_anchors(text: str) -> set[str]:
    """The ids the site gives a page's headings (Python-Markdown's toc slugs, duplicates
    numbered)."""
    anchors: set[str] = set()
    inside = False
    for line in text.splitlines():
        if _FENCE.match(line):
            inside = not inside
        heading = None if inside else re.match(r"^#{1,6} (.+)$", line)
        if not heading:
            continue
        words = unicodedata.normalize("NFKD", heading.group(1).replace("`", "").replace("**", ""))
        words = re.sub(r"[^\w\s-]", "", words.encode("ascii", "ignore").decode()).strip().lower()
        slug = re.sub(r"[-\s]+", "-", words)
        anchor, n = slug, 0
        while anchor in anchors:
            n += 1
            anchor = f"{slug}_{n}"
        anchors.add(anchor)
    return anchors


def link_problem(page: Path, target: str) -> str | None:
    """Why a link from ``page`` leads nowhere (no such file beside it, or no such heading on the
    page it names), or None."""
    path, _, fragment = target.partition("#")
    linked = (page.parent / path).resolve() if path else page
    if not linked.exists():
        shown = linked.relative_to(ROOT) if linked.is_relative_to(ROOT) else linked
        return f"{target}: no file {shown}"
    if fragment and linked.suffix == ".md" and fragment not in heading_anchors(page_text(linked)):
        return f"{target}: {linked.name} has no heading #{fragment}"
    return None


def python_names(text: str) -> list[str]:
    """Dotted names of the project's packages in backticks."""
    return [span for span in _TICKS.findall(text) if _DOTTED.match(span.strip())]


@cache
def _names_in_code() -> frozenset[str]:
    names = set()
    for package in PACKAGES:
        for path in (ROOT / package).rglob("*.py"):
            text = path.read_text("utf-8")
            names.update(re.findall(r"getLogger\(\s*\"([\w.]+)\"", text))
            names.update(re.findall(r"entry_points=\"([\w.]+)\"", text))  # plugin groups
    return frozenset(names)


def name_problem(name: str) -> str | None:
    """Why a dotted name does not import (module, or module attribute) and is no logger or
    entry-point group of the code, or None."""
    if name in _names_in_code():
        return None
    parts = name.split(".")
    if parts[0] in ("services", "schemas"):
        return f"installed as facesynth.{name}: write it so"
    for cut in range(len(parts), 0, -1):
        try:
            module = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        target: object = module
        for attribute in parts[cut:]:
            if not hasattr(target, attribute):
                return f"{'.'.join(parts[:cut])} has no {attribute!r}"
            target = getattr(target, attribute)
        return None
    return f"no module {parts[0]!r}"


# The check itself, on the README and the pages as they are.

PAGES = documents()
_IDS = [str(page.relative_to(ROOT)) for page in PAGES]


def test_the_check_reads_the_readme_and_every_page() -> None:
    assert README in PAGES and ROOT / "ARCHITECTURE.md" in PAGES
    assert len([p for p in PAGES if p.parent == DOCS]) >= 10, PAGES
    everything = "\n".join(page_text(page) for page in PAGES)
    assert len(command_lines(everything)) > 100  # the finders find them
    assert "facesynth/app/graphs/demo.toml" in named_paths(everything)
    assert "facesynth.runtime.rig_view.RigView" in python_names(everything)
    assert "docs/side-by-side.png" in linked_targets(readme_text())


@pytest.mark.parametrize("page", PAGES, ids=_IDS)
def test_every_command_parses(page: Path) -> None:
    problems = [f"{c}: {p}" for c in command_lines(page_text(page)) if (p := command_problem(c))]
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("page", PAGES, ids=_IDS)
def test_every_path_a_page_names_exists(page: Path) -> None:
    paths = named_paths(page_text(page))
    missing = sorted({p for p in paths if not (ROOT / p).exists() and not _ignored(p)})
    assert not missing, f"{page.relative_to(ROOT)} names paths that do not exist: {missing}"


@pytest.mark.parametrize("page", PAGES, ids=_IDS)
def test_every_link_leads_somewhere(page: Path) -> None:
    problems = [
        p for target in linked_targets(page_text(page)) if (p := link_problem(page, target))
    ]
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("page", PAGES, ids=_IDS)
def test_every_python_name_imports(page: Path) -> None:
    names = python_names(page_text(page))
    problems = [f"{n}: {p}" for n in sorted(set(names)) if (p := name_problem(n))]
    assert not problems, "\n".join(problems)


# The check's own parts, on text that must fail and text that must pass.

SAMPLE = """\
Run `facesynth run --profle virtual` or `facesynth nosuch --x`; it says
`facesynth sensor: error: video truncated`.

```sh
facesynth router &
facesynth control --driver record \\
    --out c.jsonl --bogus   # a comment --ignored
facesynth translator & facesynth features
```

See `facts.md`, `facesynth/feature_names.py`, `ARCHITECTURE.md`, `deploy/controllers/NAME.toml`,
![x](docs/side-by-side.png), `facesynth.profiles.FORMAT_REFERENCE`, `facesynth.link` and
`facesynth.runtime.feature_names.NAMES`.
"""


def test_the_finders_read_code_blocks_and_backticks() -> None:
    assert command_lines(SAMPLE) == [
        "facesynth router",
        "facesynth control --driver record --out c.jsonl --bogus",
        "facesynth translator",
        "facesynth run --profle virtual",
        "facesynth nosuch --x",
    ]
    assert named_paths(SAMPLE) == [
        "facts.md",
        "facesynth/feature_names.py",
        "ARCHITECTURE.md",
    ]
    assert linked_targets(SAMPLE) == ["docs/side-by-side.png"]
    assert python_names(SAMPLE) == [
        "facesynth.profiles.FORMAT_REFERENCE",
        "facesynth.link",
        "facesynth.runtime.feature_names.NAMES",
    ]


@pytest.mark.parametrize(
    ("command", "problem"),
    [
        ("facesynth run --profile virtual --driver virtual", None),
        ("facesynth sensor --video V | --camera N | --images DIR", None),
        ("facesynth run --profle virtual", "facesynth run has no option --profle"),
        ("facesynth nosuch", "no sub-command 'nosuch'"),
        ("facesynth STAGE --graph G --node N", None),
        (
            "facesynth STAGE --graph G --list-drivers",
            "facesynth sensor has no option --list-drivers",
        ),
        ("facesynth control --driver record --out c.jsonl --bogus", "no option --bogus"),
    ],
)
def test_command_problems(command: str, problem: str | None) -> None:
    found = command_problem(command)
    if problem is None:
        assert found is None
    else:
        assert found is not None and problem in found


def test_name_problems() -> None:
    assert name_problem("facesynth.runtime.feature_names.NAMES") is None
    assert name_problem("facesynth.link") is None  # a logger the code uses
    assert name_problem("facesynth.drivers") is None  # the servo drivers' entry-point group
    assert name_problem("facesynth.nosuch_group") is not None
    assert name_problem("facesynth.profiles.FORMAT_REFERENCE") is not None
    assert name_problem("facesynth.runtime.feature_names.NOPE") is not None
    assert name_problem("services.translator.core") == (
        "installed as facesynth.services.translator.core: write it so"
    )


def test_links_that_lead_nowhere_are_found() -> None:
    page = DOCS / "running.md"
    assert link_problem(README, "docs/side-by-side.png") is None
    assert link_problem(README, "docs/index.md#quick-start") is None
    assert link_problem(page, "deployment.md#several-machines") is None
    assert link_problem(page, "#what-this-host-can-run-facesynth-doctor") is None
    assert "no file docs/nosuch.md" in (link_problem(page, "nosuch.md") or "")
    assert "no file" in (link_problem(README, "side-by-side.png") or "")  # beside the README: no
    assert "has no heading #nope" in (link_problem(page, "deployment.md#nope") or "")
    assert linked_targets("[a](https://zenoh.io) [b](#x) [c](mailto:x@y) ![d](e.png)") == [
        "#x",
        "e.png",
    ]
    assert "has no heading #nope" in (link_problem(page, "#nope") or "")


def test_heading_anchors_are_the_sites() -> None:
    text = "# A ROS 2 robot: `--driver ros2`\n```\n# not a heading\n```\n## Notes\n## Notes\n"
    assert heading_anchors(text) == {"a-ros-2-robot-driver-ros2", "notes", "notes_1"}


def test_ignored_files_the_user_puts_in_place_count_as_named() -> None:
    assert _ignored("deploy/build-ca/ca.crt")
    assert not _ignored("facts.md")


def test_the_learn_walk_through_writes_into_an_ignored_folder() -> None:
    """Issue 29: the simulated head's walk-through left ``head.mcap`` (86 MB), ``head.learned``
    and ``robot.mp4`` untracked in the clone. What its commands write (``--out``, and the
    learned profile beside the session) goes into a folder that .gitignore ignores."""
    text = page_text(DOCS / "learning.md")
    section = text[text.index("## On the simulated head") :]
    section = section[: section.index("\n#")]
    commands = [c for c in command_lines(section) if c.split()[1] in ("learn", "render")]
    outputs = [m for c in commands for m in re.findall(r"--out (\S+)", c)]
    outputs += [str(Path(o).with_suffix(".learned")) for o in outputs if o.endswith(".mcap")]
    assert len(outputs) == 3, commands
    patterns = (ROOT / ".gitignore").read_text("utf-8").split()
    anchored = [p[1:].rstrip("/") for p in patterns if p.startswith("/")]
    for output in outputs:
        folder = Path(output).parts[0]
        assert len(Path(output).parts) > 1 and folder in anchored, output
        assert f"`{folder}/`" in section  # the walk-through names the folder
