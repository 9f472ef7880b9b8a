"""facesynth.app.doctor.extras: each extra's packages from facesynth's metadata, which are
installed, and which the graph needs."""

from __future__ import annotations

from facesynth.app.doctor.extras import extra_requirements, extras_findings, installed_extras

REQUIRES = [
    "numpy>=1.26",
    'opencv-python-headless>=4.10; extra == "tracker"',
    "ai-edge-litert>=2.0; (platform_machine == 'no-such-machine') and extra == \"tracker\"",
    'aiohttp>=3.9; extra == "face"',
    'python-osc>=1.8; extra == "face"',
    'facesynth[face,tracker]; extra == "chain"',
    'facesynth[chain]; extra == "all"',
    "malformed ;;; extra ==",
]


def test_requirements_by_extra_expand_our_own_and_drop_other_platforms() -> None:
    assert extra_requirements(REQUIRES) == {
        "tracker": ["opencv-python-headless"],
        "face": ["aiohttp", "python-osc"],
        "chain": ["aiohttp", "python-osc", "opencv-python-headless"],
        "all": ["aiohttp", "python-osc", "opencv-python-headless"],
    }


def test_this_installs_extras_are_read_from_its_metadata() -> None:
    state = installed_extras()
    assert {"tracker", "face", "record", "learn", "chain"} <= set(state)
    assert "test" not in state and "docs" not in state, "developers' extras are not reported"
    assert state["face"] == []  # the test environment has everything (pip install -e .[all,test])


def test_a_needed_incomplete_extra_is_a_fix_and_an_unneeded_one_a_note() -> None:
    state = {"face": [], "tracker": [], "learn": ["scikit-learn"], "record": ["mcap"]}
    findings = extras_findings(state, {"record": ["--record"], "face": ["control node c (vmc)"]})
    assert [f.line() for f in findings] == [
        "ok   extras   installed: face, tracker",
        "note extras   learn: missing scikit-learn: pip install 'facesynth[learn]'",
        "fix  extras   record: missing mcap; needed by --record: pip install 'facesynth[record]'",
    ]
