"""The README agrees with the program (issue 20): its commands, paths and Python names exist.

Read from whatever README.md holds, so text added later is checked too:

* every ``facesynth …`` command line, in a code block (a line starting with ``facesynth ``,
  with its ``\\`` continuations) or in backticks, names a sub-command of the real parser, and
  every ``--flag`` on it is one of that sub-command's options (``--help`` level: values,
  placeholders such as ``[GRAPH]``, ``…`` and ``A | B`` alternatives are not parsed);
* every repository path in backticks or in a Markdown link (``facesynth/app/graphs/demo.toml``,
  ``ARCHITECTURE.md``, ``docs/side-by-side.png``) exists; placeholders (``NAME``, ``<rig>``,
  ``…``) are skipped;
* every dotted Python name of the project in backticks (``facesynth.runtime.rig_view.RigView``)
  imports, or is a logger name the code uses (``facesynth.link``).
"""

from __future__ import annotations

import argparse
import importlib
import re
from fnmatch import fnmatch
from functools import cache
from pathlib import Path

import pytest

from facesynth.app.cli import build_parser

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
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
    """Repository paths the README names in backticks or Markdown links (no placeholders)."""
    spans = _TICKS.findall(text) + _LINK.findall(text)
    paths = []
    for span in spans:
        span = span.strip().rstrip(".,;:")
        if span.startswith(("http:", "https:", "#")) or _PLACEHOLDER.search(span):
            continue
        if _PATH.match(span) and not (_CAPS.search(span) and not (ROOT / span).exists()):
            paths.append(span)
    return paths


def python_names(text: str) -> list[str]:
    """Dotted names of the project's packages in backticks."""
    return [span for span in _TICKS.findall(text) if _DOTTED.match(span.strip())]


@cache
def _logger_names() -> frozenset[str]:
    names = set()
    for package in PACKAGES:
        for path in (ROOT / package).rglob("*.py"):
            names.update(re.findall(r"getLogger\(\s*\"([\w.]+)\"", path.read_text("utf-8")))
    return frozenset(names)


def name_problem(name: str) -> str | None:
    """Why a dotted name does not import (module, or module attribute), or None."""
    if name in _logger_names():
        return None
    parts = name.split(".")
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


# The check itself, on the README as it is.


def test_every_readme_command_parses() -> None:
    commands = command_lines(readme_text())
    assert len(commands) > 30  # the finder finds them
    problems = [f"{c}: {p}" for c in commands if (p := command_problem(c))]
    assert not problems, "\n".join(problems)


def test_every_path_the_readme_names_exists() -> None:
    paths = named_paths(readme_text())
    assert "facesynth/app/graphs/demo.toml" in paths
    missing = sorted({p for p in paths if not (ROOT / p).exists() and not _ignored(p)})
    assert not missing, f"README.md names paths that do not exist: {missing}"


def test_every_python_name_the_readme_names_imports() -> None:
    names = python_names(readme_text())
    assert "facesynth.runtime.rig_view.RigView" in names
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
        "docs/side-by-side.png",
    ]
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
    assert name_problem("facesynth.profiles.FORMAT_REFERENCE") is not None
    assert name_problem("facesynth.runtime.feature_names.NOPE") is not None


def test_ignored_files_the_user_puts_in_place_count_as_named() -> None:
    assert _ignored("deploy/build-ca/ca.crt")
    assert not _ignored("facts.md")


def test_the_learn_walk_through_writes_into_an_ignored_folder() -> None:
    """Issue 29: the simulated head's walk-through left ``head.mcap`` (86 MB), ``head.learned``
    and ``robot.mp4`` untracked in the clone. What its commands write (``--out``, and the
    learned profile beside the session) goes into a folder that .gitignore ignores."""
    text = readme_text()
    section = text[text.index("### On the simulated head") :]
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
