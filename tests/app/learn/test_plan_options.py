"""facesynth.app.learn.plan_options: every option that shapes a plan is kept in the session; a
resume uses the session's values, refuses one given otherwise (naming it), and resumes a session
written before they were kept with the defaults of that time (said in the log)."""

from __future__ import annotations

import argparse
import logging
from pathlib import Path

import pytest

from facesynth.app.cli import build_parser
from facesynth.app.learn.cli import make_plan
from facesynth.app.learn.plan import Plan, PlanError
from facesynth.app.learn.plan_options import OLD_SESSION, choose, defaults
from facesynth.app.learn.session import SessionError, metadata, read_session
from facesynth.app.recording.writer import SessionWriter
from facesynth.runtime.profiles import load_profile

PROFILE = load_profile("paper16")


def _args(*flags: str) -> argparse.Namespace:
    return build_parser().parse_args(["learn", "--profile", "paper16", *flags])


def _session(path: Path, plan: str, options: dict[str, str]) -> Path:
    SessionWriter(path, metadata=metadata("self", PROFILE, 4, ["babble"], plan, options)).close()
    return path


def test_a_new_session_takes_the_defaults_under_what_is_given() -> None:
    choice = choose(_args("--neutral-every", "7"), "fixed", 3)
    assert dict(choice.values) == {"sweep_steps": 3, "neutral_every": 7}
    assert choice.metadata() == {"learn_sweep_steps": "3", "learn_neutral_every": "7"}
    adaptive = choose(_args("--plan", "adaptive", "--members", "3"), "adaptive", 3).adaptive()
    assert (adaptive.seed, adaptive.sweep_steps, adaptive.members) == (3, 6, 3)
    assert (adaptive.region_poses, adaptive.batch, adaptive.candidates) == (250, 25, 400)


def test_every_shaping_option_is_kept_in_the_session_and_read_back(tmp_path: Path) -> None:
    flags = ["--plan", "adaptive", "--sweep-steps", "2", "--neutral-every", "9"]
    flags += ["--region-poses", "11", "--batch", "4", "--candidates", "40", "--members", "2"]
    choice = choose(_args(*flags), "adaptive", 5)
    session = read_session(_session(tmp_path / "s.mcap", "adaptive", choice.metadata()))
    assert session.options == {
        "sweep_steps": 2,
        "neutral_every": 9,
        "region_poses": 11,
        "batch": 4,
        "candidates": 40,
        "members": 2,
    }
    resumed = choose(_args(), "adaptive", 5, session.options, session.path)
    assert resumed == choice  # none given: the session's, every one
    plan = make_plan(resumed, PROFILE, None)
    assert plan.pose(1).u == make_plan(choice, PROFILE, None).pose(1).u


@pytest.mark.parametrize(
    ("flags", "named"),
    [
        (["--sweep-steps", "4"], "was babbled with --sweep-steps 2"),
        (["--neutral-every", "10"], "was babbled with --neutral-every 9"),
    ],
)
def test_a_resume_given_another_value_is_refused_naming_the_option(
    tmp_path: Path, flags: list[str], named: str
) -> None:
    path = _session(tmp_path / "s.mcap", "fixed", {"learn_sweep_steps": "2"} | NINE)
    session = read_session(path)
    with pytest.raises(PlanError, match=f"{path} {named}: resume it with that value"):
        choose(_args(*flags), "fixed", 4, session.options, path)
    same = choose(_args("--sweep-steps", "2", "--neutral-every", "9"), "fixed", 4, session.options)
    assert dict(same.values) == {"sweep_steps": 2, "neutral_every": 9}


NINE = {"learn_neutral_every": "9"}


@pytest.mark.parametrize("kind", ["fixed", "adaptive"])
def test_an_older_session_resumes_with_the_defaults_of_its_time(
    tmp_path: Path, kind: str, caplog: pytest.LogCaptureFixture
) -> None:
    session = read_session(_session(tmp_path / "old.mcap", kind, {}))
    assert session.options == {}
    with caplog.at_level(logging.INFO, "facesynth.learn"):
        choice = choose(_args(), kind, 4, session.options, session.path)
    assert dict(choice.values) == OLD_SESSION[kind] == defaults(kind)
    assert f"{session.path} does not say which plan options" in caplog.text
    assert "--sweep-steps 3" in caplog.text if kind == "fixed" else "--sweep-steps 6" in caplog.text
    # what is given is what the user says it was babbled with
    given = choose(_args("--sweep-steps", "5"), kind, 4, session.options, session.path)
    assert given.values["sweep_steps"] == 5


def test_options_that_cannot_make_a_plan_are_one_line_errors(tmp_path: Path) -> None:
    with pytest.raises(PlanError, match="--batch shapes the adaptive plan only"):
        choose(_args("--batch", "3"), "fixed", 0)
    with pytest.raises(PlanError, match="candidates >= the batch"):
        choose(_args("--plan", "adaptive", "--batch", "30", "--candidates", "20"), "adaptive", 0)
    with pytest.raises(PlanError, match="at most every other pose"):
        choose(_args("--neutral-every", "1"), "fixed", 0)
    with pytest.raises(PlanError, match="--sweep-steps 1000000 is too large"):
        choose(_args("--sweep-steps", "1000000"), "fixed", 0)
    bad = _session(tmp_path / "bad.mcap", "fixed", {"learn_sweep_steps": "three"})
    with pytest.raises(SessionError, match="the session's --sweep-steps 'three' is not a whole"):
        read_session(bad)


def test_the_fixed_plan_made_from_a_choice_is_the_plan_of_its_options() -> None:
    choice = choose(_args("--sweep-steps", "1", "--neutral-every", "4"), "fixed", 2)
    plan = make_plan(choice, PROFILE, None)
    assert isinstance(plan, Plan)
    assert [plan.pose(i).kind for i in range(5)] == [
        "neutral",
        "sweep",
        "sweep",
        "sweep",
        "neutral",
    ]
