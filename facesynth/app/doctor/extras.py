"""The ``facesynth`` extras installed here: each extra's packages, read from facesynth's own
metadata (``pip install 'facesynth[tracker]'`` …), looked up without importing them.

An extra the graph's plugins need (their ``needs_extra``) and that is incomplete is a line to
fix; the others are said once, installed or not.
"""

from __future__ import annotations

import importlib.metadata
import re
from collections.abc import Mapping

from facesynth.app.doctor.report import Finding

FAMILY = "extras"
_NAME = re.compile(r"^\s*([A-Za-z0-9][A-Za-z0-9._-]*)(?:\[([^\]]*)\])?")
_EXTRA = re.compile(r"""extra\s*==\s*["']([^"']+)["']""")


def extra_requirements(requires: list[str]) -> dict[str, list[str]]:
    """``{extra: [distribution, …]}`` from a distribution's ``Requires-Dist`` lines (pure);
    a requirement on facesynth's own extras (``chain``) is expanded, and one whose other
    markers do not hold on this host (a platform) is left out."""
    direct: dict[str, list[str]] = {}
    for line in requires:
        requirement, _, marker = line.partition(";")
        extra = _EXTRA.search(marker)
        name = _NAME.match(requirement)
        if extra is None or name is None or not _marker_holds(marker):
            continue
        entry = name.group(1)
        if entry.lower() == "facesynth":
            entry = "+" + (name.group(2) or "")
        direct.setdefault(extra.group(1), []).append(entry)

    def expand(extra: str, seen: frozenset[str]) -> list[str]:
        out: list[str] = []
        for entry in direct.get(extra, []):
            if entry.startswith("+"):
                for inner in entry[1:].split(","):
                    if inner.strip() and inner.strip() not in seen:
                        out += expand(inner.strip(), seen | {inner.strip()})
            elif entry not in out:
                out.append(entry)
        return list(dict.fromkeys(out))

    return {extra: expand(extra, frozenset({extra})) for extra in direct}


def _marker_holds(marker: str) -> bool:
    """Whether a requirement's environment marker holds here (with ``packaging`` when
    installed; the extra itself is judged by the caller)."""
    try:
        from packaging.markers import Marker
    except ImportError:  # pragma: no cover - pip's own packaging is nearly always there
        return True
    extra = _EXTRA.search(marker)
    try:
        return bool(Marker(marker).evaluate({"extra": extra.group(1) if extra else ""}))
    except Exception:  # a marker packaging cannot read: count the requirement in
        return True


def installed(distribution: str) -> bool:
    """Whether a distribution is installed."""
    try:
        importlib.metadata.distribution(distribution)
    except importlib.metadata.PackageNotFoundError:
        return False
    return True


#: Extras for working on facesynth, not for running it: doctor does not report them.
DEVELOPER_EXTRAS = frozenset({"test", "docs"})


def installed_extras() -> dict[str, list[str]]:
    """``{extra: [missing distribution, …]}`` for facesynth's extras (empty list: complete);
    the developers' extras (test tools, the docs site) left out."""
    try:
        requires = importlib.metadata.requires("facesynth") or []
    except importlib.metadata.PackageNotFoundError:
        return {}
    extras = extra_requirements(requires)
    return {
        extra: [name for name in names if not installed(name)]
        for extra, names in extras.items()
        if extra not in DEVELOPER_EXTRAS
    }


def extras_findings(
    state: Mapping[str, list[str]], needed: Mapping[str, list[str]]
) -> list[Finding]:
    """One line for the complete extras, one per incomplete one (pure)."""
    complete = sorted(extra for extra, missing in state.items() if not missing)
    findings = []
    if complete:
        findings.append(Finding(FAMILY, "installed", ", ".join(complete)))
    for extra in sorted(set(state) | set(needed)):
        missing = state.get(extra)
        if missing == []:
            continue
        who = needed.get(extra)
        what = f"missing {', '.join(missing)}" if missing else "unknown to this install"
        if who:
            what += f"; needed by {', '.join(who)}"
        findings.append(
            Finding(
                FAMILY,
                extra,
                what,
                good=False,
                needed=bool(who),
                fix=f"pip install 'facesynth[{extra}]'",
            )
        )
    return findings
