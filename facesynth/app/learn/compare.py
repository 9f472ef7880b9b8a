"""Compare babbling plans and fits on a simulated head, on the same pose budget.

``python -m facesynth.app.learn.compare --head simhead16 --poses 620`` babbles the head in
process (:mod:`facesynth.app.learn.inprocess`) three ways, each ``--poses`` poses, and fits
each:

* ``uniform``: uniform random poses, the old fit (no recombination): the babbler the
  learning figures of ``docs/learning.md`` were measured with;
* ``plan``: :class:`~facesynth.app.learn.plan.Plan` (sweeps, scrambled Halton), the old fit;
* ``adaptive``: :class:`~facesynth.app.learn.adaptive.AdaptivePlan` (fine sweeps, region
  poses, least-sure poses), the fit with ``RECOMBINED`` recombined faces.

Every profile is measured on the same separate babbling of ``--test`` uniform random poses
(:func:`~facesynth.app.learn.inprocess.held_out_error`): the command error, raw and effective,
with each fit's own held-out figures and seconds beside it. Every fit averages
:data:`~facesynth.app.learn.models.MLP_MEMBERS` MLPs a candidate, as ``facesynth learn``'s.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Iterator
from dataclasses import replace

import numpy as np

from facesynth.app.learn.adaptive import AdaptiveOptions, AdaptivePlan
from facesynth.app.learn.fit import FitOptions, fit_learned_profile
from facesynth.app.learn.inprocess import SimBabbler, babble, held_out_error, uniform_poses
from facesynth.app.learn.models import MLP_MEMBERS
from facesynth.app.learn.plan import Plan, PlanOptions
from facesynth.runtime.feature_names import NAMES
from facesynth.runtime.profiles import Profile, load_profile

WAYS = ("uniform", "plan", "adaptive")
#: Faces the adaptive way's fit recombines from its region poses (off in ``FitOptions``).
RECOMBINED = 2000


def _planned(plan: Plan | AdaptivePlan, poses: int) -> Iterator[tuple[str, np.ndarray]]:
    for index in range(poses):
        pose = plan.pose(index)
        yield pose.kind, np.array(pose.u)


def run(
    profile: Profile, head: str, poses: int, test_poses: int, ways: tuple[str, ...], seed: int
) -> list[dict[str, object]]:
    """One row per way: its held-out errors on the shared test poses and its fit's figures."""
    babbler = SimBabbler(profile, head)
    test = babble(babbler, uniform_poses(len(profile.servos), test_poses, seed + 1000))
    rows = []
    for way in ways:
        options = FitOptions(seed=seed, recombined=0, mlp_members=MLP_MEMBERS)
        if way == "uniform":
            data = babble(babbler, uniform_poses(len(profile.servos), poses, seed))
        elif way == "plan":
            data = babble(babbler, _planned(Plan(len(profile.servos), PlanOptions(seed)), poses))
        else:
            servos = tuple(s.name for s in profile.servos)
            adaptive = AdaptivePlan(servos, list(NAMES), AdaptiveOptions(seed=seed))
            data = babble(
                babbler,
                _planned(adaptive, poses),
                adaptive.observe,
            )
            options = replace(options, recombined=RECOMBINED)
        begun, cpu = time.perf_counter(), time.process_time()
        fitted = fit_learned_profile(data, profile, options)
        seconds, cpu = time.perf_counter() - begun, time.process_time() - cpu
        assert fitted.learned is not None
        report = fitted.learned.report
        raw, effective = held_out_error(fitted, test)
        rows.append(
            {
                "way": way,
                "raw": raw,
                "effective": effective,
                "fit_raw": float(np.mean(list(report.servo_error.values()))),
                "fit_effective": float(np.mean(list(report.effective_error.values()))),
                "model": report.model,
                "fit_seconds": seconds,
                "fit_cpu": cpu,
                "notes": [
                    n
                    for n in report.notes
                    if n.startswith(("region", "symmetric")) or "recombined" in n
                ],
            }
        )
    return rows


def main(argv: list[str] | None = None) -> int:
    """Print the comparison (see the module)."""
    parser = argparse.ArgumentParser(prog="python -m facesynth.app.learn.compare")
    parser.add_argument("--head", default="simhead16")
    parser.add_argument("--profile", default="head16_hardware")
    parser.add_argument("--poses", type=int, default=620)
    parser.add_argument("--test", type=int, default=160)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--ways", default=",".join(WAYS))
    args = parser.parse_args(argv)
    ways = tuple(w for w in args.ways.split(",") if w)
    unknown = [w for w in ways if w not in WAYS]
    if unknown:
        parser.error(f"unknown ways {unknown} (known: {', '.join(WAYS)})")
    profile = load_profile(args.profile)
    for row in run(profile, args.head, args.poses, args.test, ways, args.seed):
        print(
            f"{args.head} {row['way']:<9} held-out command error on {args.test} uniform poses: "
            f"raw {row['raw']:.3f} effective {row['effective']:.3f}; the fit's own: raw "
            f"{row['fit_raw']:.3f} effective {row['fit_effective']:.3f} ({row['model']}, "
            f"{row['fit_seconds']:.1f} s, {row['fit_cpu']:.1f} s of CPU)",
            flush=True,
        )
        for note in row["notes"]:  # type: ignore[attr-defined]
            print(f"    {note}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
