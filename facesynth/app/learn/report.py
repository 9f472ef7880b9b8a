"""The fit's report as text (``facesynth learn``, ``python -m facesynth.app.learn.fit``)."""

from __future__ import annotations

from facesynth.runtime.profiles import Profile
from facesynth.runtime.profiles.learned import command_range


def format_report(profile: Profile) -> str:
    """The fit's report: the models compared, then each servo's held-out command error, raw
    and (where the file has it) effective; issue 17's goal is measured on the effective one.
    The errors cover the fitted servos only (``over N of M servos``); the others are listed as
    dead (swept, moved nothing), not exercised (never moved) or swept one way only."""
    if profile.learned is None:
        return f"profile {profile.name} is not learned"
    learned, report = profile.learned, profile.learned.report
    effective = report.effective_error
    lines = [
        f"{profile.name}: {report.model} from {len(learned.inputs)} inputs, "
        f"{report.samples} samples ({report.held_out} held out, {report.dropped} dropped), "
        f"fitted in {report.fit_seconds:.1f} s",
        f"held-out command error (fraction of range) over {len(learned.outputs)} of "
        f"{len(profile.servos)} servos, raw: "
        + ", ".join(f"{name} {error:.3f}" for name, error in report.candidates.items()),
    ]
    if report.effective_candidates:
        lines.append(
            "effective (both clipped into the responsive range; the goal): "
            + ", ".join(f"{n} {e:.3f}" for n, e in report.effective_candidates.items())
        )
    low, high = command_range(learned)
    for index, name in enumerate(learned.outputs):
        line = f"  {name:<20} {report.servo_error[name]:.3f}"
        if name in effective:
            line += f"  effective {effective[name]:.3f}"
            line += f"  responsive {low[index] + 0.0:+.2f} .. {high[index] + 0.0:+.2f}"
        lines.append(line)
    for name in learned.dead:
        if name in report.not_exercised:
            state = "not exercised: never moved while babbling"
        elif name in report.one_way:
            state = "swept one way only"
        else:
            state = "dead"
        lines.append(f"  {name:<20} {state} (kept at neutral)")
    lines.extend(f"note: {note}" for note in report.notes)
    return "\n".join(lines)
