"""The one call from ``facesynth learn`` into the fitting: a session's poses in, the learned
profile written (named after its file), the report out. The fitting itself is tested in
test_fit*.py; here it runs for real on a small synthetic babbling set."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from synthetic_babble import hardware, planned_babble, synthetic_babble

from facesynth.app.cli import main
from facesynth.app.learn import cli
from facesynth.app.learn.dataset import BabbleSet
from facesynth.app.learn.session import metadata
from facesynth.app.recording.layout import Layout
from facesynth.app.recording.writer import SessionWriter
from facesynth.runtime import codec
from facesynth.runtime.profiles import load_profile
from facesynth.schemas.messages import BabbleSample

POSES = 240


@pytest.fixture(autouse=True)
def _one_mlp_a_candidate(monkeypatch: pytest.MonkeyPatch) -> None:
    """The command's plumbing is tested here: one MLP a candidate keeps it fast (that the
    command fits with the averaged MLPs is tested in test_mlp_members.py)."""
    monkeypatch.setattr(cli, "MLP_MEMBERS", 1)


def test_the_fitting_is_called_and_its_profile_saved(tmp_path: Path) -> None:
    babble = synthetic_babble(POSES)
    out = tmp_path / "head.learned"
    report = cli.fit(babble, hardware(), out)
    assert report.endswith(f"wrote {out}") and "held-out command error" in report
    learned = load_profile(str(out))
    assert learned.name == "head"  # named after its file, not after the hardware profile
    assert learned.learned is not None and learned.learned.plan_steps > 0
    assert [s.name for s in learned.servos] == [s.name for s in hardware().servos]


def _session(path: Path, babble: BabbleSet) -> None:
    profile = hardware()
    writer = SessionWriter(path, metadata=metadata("self", profile, 0, ["babble"]))
    for seq, (row, face, kind) in enumerate(
        zip(babble.commands, babble.faces, babble.kinds, strict=True)
    ):
        sample = BabbleSample(
            seq=seq,
            t_capture_ns=seq,
            t_media_ns=seq,
            profile=profile.name,
            kind=kind,
            commanded=dict(zip(babble.servos, row.tolist(), strict=True)),
            features={
                name: value
                for name, value in zip(babble.inputs, face.tolist(), strict=True)
                if math.isfinite(value)
            },
        )
        for entry in Layout().entries("facesynth/self/babble", codec.encode(sample), seq, seq):
            writer.write(entry)
    writer.close()


def test_a_complete_session_is_fitted_without_babbling(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "s.mcap"
    _session(path, synthetic_babble(POSES))
    argv = ["learn", "--profile", "head16_hardware", "--out", str(path), "--poses", "2"]
    assert main([*argv, "--video", "x"]) == 0
    out = capsys.readouterr().out
    assert f"{path} already holds {POSES} poses (--poses 2): nothing to babble" in out
    assert "held-out command error" in out and f"wrote {tmp_path / 's.learned'}" in out
    # --fit-only takes the session's own profile
    target = tmp_path / "head.learned"
    assert main(["learn", "--fit-only", str(path), "--out-profile", str(target)]) == 0
    assert f"wrote {target}" in capsys.readouterr().out
    first, second = load_profile(str(tmp_path / "s.learned")), load_profile(str(target))
    assert first.learned is not None and second.learned is not None
    assert first.learned.inputs == second.learned.inputs
    assert np.array_equal(first.learned.reach_high.data, second.learned.reach_high.data)


def test_a_session_not_yet_swept_is_refused_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """``--poses 40`` on sixteen servos: ten not swept yet. The fit refuses (exit 2, one line
    naming them and how to finish), after a resumed run and with --fit-only, and writes
    nothing."""
    monkeypatch.chdir(tmp_path)
    _session(tmp_path / "s.mcap", planned_babble(40))
    runs = [
        ["learn", "--profile", "head16_hardware", "--out", "s.mcap", "--poses", "40"],
        ["learn", "--fit-only", "s.mcap"],
    ]
    for argv in runs:
        assert main([*argv, "--video", "x"] if "--out" in argv else argv) == 2
        err = capsys.readouterr().err
        assert err.count("facesynth learn: error: ") == 1 and "Traceback" not in err
        line = err[err.index("facesynth learn: error: ") :].strip()
        assert "\n" not in line
        assert line.startswith("facesynth learn: error: s.mcap: 10 of 16 servos not swept yet: ")
        assert "left_eye_y (one way only), right_inner_cheek, " in line and "jaw" in line
        assert "--out s.mcap and --poses 100 or more" in line and "--partial" in line
        assert not (tmp_path / "s.learned").exists()


def test_a_partial_fit_writes_and_says_what_is_missing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    path = tmp_path / "s.mcap"
    _session(path, planned_babble(40))
    assert main(["learn", "--fit-only", str(path), "--partial"]) == 0
    out = capsys.readouterr().out
    assert f"wrote {tmp_path / 's.learned'}" in out
    assert " of 16 servos, raw: " in out
    assert "jaw                  not exercised: never moved while babbling (kept at neutral)" in out
    assert "note: partial fit: 10 of 16 servos not swept yet" in out
    assert "--partial: 10 of 16 servos not swept yet, kept at neutral" in caplog.text
    learned = load_profile(str(tmp_path / "s.learned")).learned
    assert learned is not None and "jaw" in learned.dead and "jaw" not in learned.outputs
    assert learned.report.not_exercised[-1] == "left_lower_lip"
    # facesynth profile show says the same
    assert main(["profile", "show", str(tmp_path / "s.learned")]) == 0
    shown = capsys.readouterr().out
    assert "10 not swept" in shown
    jaw = next(line for line in shown.splitlines() if " jaw " in line)
    assert jaw.endswith("learned: not exercised (never moved while babbling), kept at neutral")
