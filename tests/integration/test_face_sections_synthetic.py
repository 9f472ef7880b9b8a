"""The paper's face sections on synthetic faces with known motion, through every shipped profile
and both tracker models (``facesynth bench fidelity``).

A still frame of the bundled video is warped into a smile, a brow raise, a frown, a jaw drop,
gaze in four directions (the irises redrawn; vertical gaze also with the lids following) and
eyes widened or squinted with the irises still (``facesynth.app.simhead.faces``). Each
runs through the real tracker, F and T of every profile. An expression *passes* a profile when
its expected servos move at least 15 % of their travel the right way and the servos of the other
face regions stay within 20 % of theirs (``facesynth.app.bench.fidelity``).

The measured table (docs/benchmarks.md, "Fidelity") is pinned here: every expression that passes
today must keep passing; the ones listed as misses are the measured weak spots (for example
head16's geometric brows read a jaw drop and a look to the right as a brow movement, through the
tracker's own coupling of the upper and lower face; head16_bs, whose brows follow the
blendshapes, does not).
"""

from __future__ import annotations

import pytest

from facesynth.app.bench.fidelity import (
    CROSS_TALK,
    MIN_MOVE,
    PROFILES,
    FidelityRow,
    bench_fidelity,
    format_fidelity,
)
from facesynth.app.data import sample_video
from facesynth.app.simhead.faces import EXPRESSIONS

MODELS = ("fast", "full")
#: The measured misses per (profile, model); every other expression must pass.
MISSES: dict[tuple[str, str], set[str]] = {
    ("paper16", "full"): {"smile", "jaw_open"},
    ("head16", "full"): {"jaw_open", "look_right"},
    ("head16_bs", "full"): set(),
    ("virtual", "full"): {"brow_raise", "frown", "jaw_open", "look_right"},
    ("virtual_bs", "full"): {"brow_raise", "frown", "jaw_open"},
    ("arkit52", "full"): {"brow_raise", "look_up", "eyes_wide", "squint"},
    ("paper16", "fast"): {"smile", "brow_raise", "frown", "jaw_open"},
    ("head16", "fast"): {"smile", "brow_raise", "frown", "jaw_open"},
    ("head16_bs", "fast"): {"smile", "brow_raise", "frown", "jaw_open"},
    ("virtual", "fast"): {
        "brow_raise",
        "frown",
        "jaw_open",
        "look_up_lids",
        "look_down_lids",
        "eyes_wide",
        "squint",
    },
    ("virtual_bs", "fast"): {"brow_raise", "frown", "jaw_open", "eyes_wide", "squint"},
    ("arkit52", "fast"): set(EXPRESSIONS),  # no blendshapes without the full model
}


@pytest.fixture(scope="module")
def rows() -> list[FidelityRow]:
    return bench_fidelity(str(sample_video()), MODELS, PROFILES)


def test_every_expression_runs_through_every_profile_and_model(rows: list[FidelityRow]) -> None:
    assert len(rows) == len(MODELS) * len(PROFILES) * len(EXPRESSIONS)
    assert {(r.profile, r.model) for r in rows} == set(MISSES)
    text = format_fidelity(rows)
    assert "head16_bs / full: 12/12 expressions pass" in text
    assert f"within {CROSS_TALK:.2f}" in text and f">= {MIN_MOVE:.2f}" in text


@pytest.mark.parametrize(("profile", "model"), sorted(MISSES), ids="{0[0]}-{0[1]}".format)
def test_expressions_reach_the_right_servos(
    rows: list[FidelityRow], profile: str, model: str
) -> None:
    chosen = {r.expression: r for r in rows if r.profile == profile and r.model == model}
    failing = {name for name, r in chosen.items() if not (r.right_way and r.within_bound)}
    detail = {name: (chosen[name].worst_expected, chosen[name].cross_talk) for name in failing}
    assert failing <= MISSES[(profile, model)], detail


@pytest.mark.parametrize("profile", PROFILES)
def test_with_the_default_model_no_expected_servo_moves_the_wrong_way(
    rows: list[FidelityRow], profile: str
) -> None:
    """``full`` (the default): every expected servo moves the right way, if not always far
    enough, except paper16's lip corners, whose Table 1 nose distances read the synthetic smile
    (corners out and up) as a slight depress."""
    for row in rows:
        if row.profile != profile or row.model != "full":
            continue
        for servo, move in row.expected.items():
            if (profile, row.expression) == ("paper16", "smile"):
                continue
            assert move > 0, (row.expression, servo, move)


def test_blendshape_profiles_beat_their_geometric_twins(rows: list[FidelityRow]) -> None:
    def passed(profile: str) -> int:
        return sum(
            r.right_way and r.within_bound
            for r in rows
            if r.profile == profile and r.model == "full"
        )

    assert passed("head16_bs") > passed("head16")
    assert passed("virtual_bs") > passed("virtual")


def test_lids_do_not_read_as_gaze(rows: list[FidelityRow]) -> None:
    """Widening or squinting the eyes, irises still, keeps every gaze servo within the bound
    with the full model, and a vertical look reads on both eyes with the lids following."""
    for row in rows:
        if row.model != "full" or row.profile == "arkit52":
            continue
        if row.expression in ("eyes_wide", "squint"):
            gaze = {n: abs(v) for n, v in row.moves.items() if "eye_" in n or "gaze" in n}
            assert max(gaze.values()) <= CROSS_TALK, (row.profile, row.expression, gaze)
        if row.expression in ("look_up_lids", "look_down_lids"):
            assert len(row.expected) == 2 and min(row.expected.values()) >= MIN_MOVE
