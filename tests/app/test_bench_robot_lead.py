"""What ``bench robot`` leads with: mean ρ and amplitude over the features the performer moves
and the robot moved while babbling, then every moved feature; end to end on a generated head
with a profile learned for it in process."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from facesynth.app.bench.robot import HeadRun, ProfileRun, RobotBench
from facesynth.app.bench.robot_compare import FeatureRow, summarize
from facesynth.app.bench.robot_report import format_robot, robot_json
from facesynth.app.learn import inprocess
from facesynth.runtime.profiles import Profile
from facesynth.runtime.profiles.learned import shown_inputs


def _row(
    name: str, rho: float, ratio: float, moved: bool = True, in_reach: float = float("nan")
) -> FeatureRow:
    return FeatureRow(
        name, "inter-ocular distance", 100, 0.2, 0.2 * ratio, rho, ratio, moved, True, in_reach
    )


def _bench(babbled: frozenset[str] | None, reach_from: str | None = None) -> RobotBench:
    written = [_row("jaw_open", 0.8, 1.0), _row("lips_part", 0.2, 0.5), _row("head_yaw", 0.0, 0.0)]
    learned = [
        _row("jaw_open", 0.9, 0.9, in_reach=1.1),
        _row("lips_part", 0.6, 0.7, in_reach=0.9),
        _row("head_yaw", 0.1, 0.1),
    ]
    runs = [
        ProfileRun(name, rows, summarize(rows), 1.0, 1, 0.5)
        for name, rows in (("head16", written), ("learned", learned))
    ]
    return RobotBench("v", 100, 24.0, "full", 1.0, [HeadRun("seed:1", runs, babbled, reach_from)])


def test_the_table_leads_with_the_babbled_features_then_every_moved_one() -> None:
    text = format_robot(_bench(frozenset({"jaw_open", "lips_part", "mouthClose"})))
    lines = text.splitlines()
    at = lines.index("head seed:1: 100 frames")
    assert "head16" in lines[at + 1] and "learned" in lines[at + 1]
    assert " ".join(lines[at + 2].split()) == (
        "lead, 2 moved & babbled: rho / ratio / in reach 0.50 / 0.75 / - 0.75 / 0.80 / 1.00"
    )
    assert " ".join(lines[at + 3].split()) == "all 3 moved: rho / ratio 0.33 / 0.50 0.53 / 0.70"
    assert lines[at + 4] == "  moved, not babbled (left out of the lead): head_yaw"
    assert lines[at + 5].split()[0] == "feature"
    data = robot_json(_bench(frozenset({"jaw_open", "lips_part"})))
    (head,) = data["heads"]
    assert head["babbled"] == ["jaw_open", "lips_part"]
    learned = head["profiles"][1]["lead"]
    assert learned["basis"] == "babbling" and learned["features"] == ["jaw_open", "lips_part"]
    assert learned["mean_rho"] == pytest.approx(0.75)
    assert learned["median_reach_ratio"] == pytest.approx(1.0)
    assert head["profiles"][0]["lead"]["median_reach_ratio"] is None
    assert head["profiles"][1]["features"][0]["reach_ratio"] == pytest.approx(1.1)


def test_the_table_says_whose_reach_the_ratio_in_reach_is_taken_against() -> None:
    lines = format_robot(_bench(frozenset({"jaw_open"}), "learned")).splitlines()
    at = lines.index("head seed:1: 100 frames")
    assert lines[at + 5] == "  in reach: against the robot's reach as learned records it"
    assert robot_json(_bench(None, "learned"))["heads"][0]["reach_from"] == "learned"
    assert "in reach: against" not in format_robot(_bench(None))


def test_a_head_not_babbled_leads_with_what_some_profile_reached() -> None:
    text = format_robot(_bench(None))
    assert "lead, 3 moved & reached: rho / ratio" in text and "moved, not babbled" not in text
    (head,) = robot_json(_bench(None))["heads"]
    assert head["babbled"] is None and head["profiles"][0]["lead"]["basis"] == "reach"


@pytest.mark.slow
@pytest.mark.timeout(900)
def test_bench_robot_learns_a_generated_head_and_leads_with_what_it_babbled(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    from facesynth.app.cli import main

    learned: list[Profile] = []
    original = inprocess.learn_simhead

    def keep(*args: object, **kwargs: object) -> Profile:
        profile = original(*args, **kwargs)  # type: ignore[arg-type]
        learned.append(profile)
        return profile

    monkeypatch.setattr(inprocess, "learn_simhead", keep)
    out = tmp_path / "robot.json"
    argv = ["bench", "robot", "--frames", "72", "--head", "seed:2", "--profile", "head16"]
    assert main([*argv, "--learn-poses", "60", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    (profile,) = learned
    assert profile.learned is not None
    (head,) = json.loads(out.read_text())["heads"]
    assert head["head"] == "seed:2"
    assert [run["profile"] for run in head["profiles"]] == ["head16", "learned"]
    # What the robot moved while babbling: the learned fit's own record.
    babbled = set(shown_inputs(profile.learned))
    assert head["babbled"] == sorted(babbled) and babbled
    moved = {row["feature"] for row in head["profiles"][0]["features"] if row["moved"]}
    claimed = sorted(moved & babbled)
    assert claimed and len(claimed) < len(moved)  # she moves some a 16-servo head cannot
    for run in head["profiles"]:
        assert run["lead"]["basis"] == "babbling"
        assert run["lead"]["features"] == claimed
    lines = text.splitlines()
    at = lines.index("head seed:2: 72 frames")
    assert lines[at + 2].startswith(f"  lead, {len(claimed)} moved & babbled: rho / ratio")
    assert lines[at + 3].startswith(f"  all {len(moved)} moved: rho / ratio")
    left = sorted(moved - babbled)
    assert lines[at + 4] == f"  moved, not babbled (left out of the lead): {', '.join(left)}"
