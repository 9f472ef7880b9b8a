"""The named files the graph reads: each robot's profile (it loads, and its control node's
driver can show it: :func:`facesynth.app.profile_choice.check_fit`) and each performer
calibration (it is found and loads)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from facesynth.app.doctor.report import Finding
from facesynth.app.profile_choice import ProfileFitError, check_fit
from facesynth.runtime.calibration import load_calibration, resolve_calibration
from facesynth.runtime.profiles import ProfileError, load_profile


def profile_findings(profiles: Sequence[tuple[str, str, Any]]) -> list[Finding]:
    """One line per robot node: its profile loads and fits its driver."""
    findings = []
    for node, name, driver in profiles:
        subject = f"{name} (node {node})"
        try:
            profile = load_profile(name)
            if driver is not None:
                check_fit(driver, profile)
        except ProfileError as exc:
            findings.append(
                Finding(
                    "profile",
                    subject,
                    str(exc),
                    good=False,
                    needed=True,
                    fix="facesynth profile list shows the profiles found; facesynth profile "
                    "check NAME says what is wrong with one",
                )
            )
            continue
        except ProfileFitError as exc:
            text, _, fix = str(exc).partition(": choose ")
            findings.append(
                Finding("profile", subject, text, good=False, needed=True, fix=f"choose {fix}")
            )
            continue
        findings.append(Finding("profile", subject, f"loads, {len(profile.servos)} controls"))
    return findings


def calibration_findings(calibrations: Sequence[tuple[str, str]]) -> list[Finding]:
    """One line per calibration a node names: found and valid."""
    findings = []
    for node, name in calibrations:
        subject = f"{name} (node {node})"
        try:
            path = resolve_calibration(name)
            load_calibration(name)
        except ValueError as exc:
            findings.append(
                Finding(
                    "calibration",
                    subject,
                    str(exc),
                    good=False,
                    needed=True,
                    fix=f"record it with facesynth calibrate {name}, or run without "
                    "--calibration (F learns the neutral as it goes)",
                )
            )
            continue
        findings.append(Finding("calibration", subject, f"{path}: loads"))
    return findings
