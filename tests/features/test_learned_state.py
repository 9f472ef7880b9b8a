"""services.features.state and the features shell: a restarted F picks up the neutral and ranges
it learned (per rig and performer), never re-learns from whatever face comes next, and says so."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import msgspec
import numpy as np
import pytest
from synthetic_face import MESH, S, move, points_message

from facesynth.runtime.clock import FAKE_EPOCH_NS
from facesynth.runtime.testing import StageRun
from facesynth.services.features.core import FeatureProcessor
from facesynth.services.features.expressions import BROW
from facesynth.services.features.service import StateKeeping, serve_features
from facesynth.services.features.state import (
    LearnedState,
    StateError,
    check_name,
    load_state,
    parse_state,
    restore,
    save_state,
    snapshot,
    state_path,
)

FPS = 30


def neutral_then(face: np.ndarray, frames: int, start: int = 0) -> list:
    """``frames`` frames of ``face`` from frame ``start`` (30 fps media time)."""
    return [
        points_message(face, seq=i, t_media_ns=round(i * S / FPS))
        for i in range(start, start + frames)
    ]


RAISED = move(MESH, BROW["right"].mesh, dy=0.08)  # a raised right brow


def learned_processor(auto: bool = False) -> FeatureProcessor:
    processor = FeatureProcessor(neutral_seconds=1.0, auto_range=auto)
    for points in neutral_then(MESH, 40):
        processor.process(points)
    return processor


def test_a_snapshot_restores_into_a_fresh_processor_giving_the_same_features() -> None:
    first = learned_processor()
    state = snapshot(first, "lab", "alice", 123)
    fresh = FeatureProcessor(neutral_seconds=1.0)
    restore(fresh, state)
    frame = points_message(RAISED, seq=50, t_media_ns=50 * S // FPS)
    a, b = first.process(frame), fresh.process(frame)
    assert b.neutral_ready and b.deltas == a.deltas and b.named == a.named
    assert b.named["brow_raise_inner_right"] > 0.3


def test_without_the_state_a_restarted_processor_learns_the_wrong_neutral() -> None:
    """The failure the state prevents: F restarted while the performer raises a brow."""
    first = learned_processor()
    frame = points_message(RAISED, seq=50, t_media_ns=50 * S // FPS)
    right = first.process(frame).named["brow_raise_inner_right"]
    naive = FeatureProcessor(neutral_seconds=1.0)
    for points in neutral_then(RAISED, 40, start=100):
        features = naive.process(points)
    assert right > 0.3 and abs(features.named["brow_raise_inner_right"]) < 0.05


def test_auto_range_state_keeps_the_rolling_neutral_and_the_adapted_ranges() -> None:
    first = learned_processor(auto=True)
    for points in neutral_then(RAISED, 30 * 8, start=40):  # held 8 s: the neutral rolls
        first.process(points)
    state = snapshot(first, "lab", "alice", 1)
    assert state.named_neutral != snapshot(learned_processor(True), "lab", "alice", 1).named_neutral
    fresh = FeatureProcessor(neutral_seconds=1.0, auto_range=True)
    restore(fresh, state)
    assert fresh.auto is not None
    assert fresh.auto.named == first.auto.named  # type: ignore[union-attr]
    assert fresh.auto.range.ranges() == first.auto.range.ranges()  # type: ignore[union-attr]


def test_there_is_nothing_to_snapshot_before_the_neutral_is_learned() -> None:
    with pytest.raises(StateError, match="not learned yet"):
        snapshot(FeatureProcessor(), "lab", "alice", 1)


def test_files_round_trip_atomically_and_per_rig_and_performer(tmp_path: Path) -> None:
    state = snapshot(learned_processor(), "lab", "alice", 5)
    path = state_path(tmp_path, "lab", "alice")
    assert path == tmp_path / "lab" / "alice.json"
    save_state(path, state)
    assert load_state(path) == state
    assert [p.name for p in path.parent.iterdir()] == ["alice.json"]  # no temporary left
    assert load_state(state_path(tmp_path, "lab", "bob")) is None


def _state_json(**changes: object) -> bytes:
    data = msgspec.to_builtins(snapshot(learned_processor(), "lab", "alice", 5))
    data.update(changes)
    return json.dumps(data).encode()


@pytest.mark.parametrize(
    ("data", "detail"),
    [
        (b"", "Input data was truncated"),
        (b"{not json", "malformed"),
        (b"[]", "Expected `object`"),
        (_state_json(version=2), "version 2 is not supported"),
        (_state_json(neutral=[0.5] * 67), "neutral has 67 values, needs 68"),
        (_state_json(frame=[0.0] * 135 + [None]), "Expected `float`, got `null`"),
        (_state_json(neutral_mesh=[1.0] * 10), "neutral_mesh has 10 values, needs 1404"),
        (_state_json(named_neutral={"tail_wag": 0.1}), "unknown named features ['tail_wag']"),
        (_state_json(ranges={"jaw_open": [0.2, 0.5]}), "ranges ['jaw_open'] need min < 0 < max"),
        (_state_json(extra=1), "Object contains unknown field `extra`"),
        (_state_json(format="other"), "Invalid enum value 'other'"),
        # F would publish displacements every receiver refuses (found by tests/fuzz)
        (
            _state_json(frame=[0.0] * 135 + [1e7]),
            "frame has a value that is not a finite number within ±1000",
        ),
        (_state_json(ranges={"jaw_open": [-1e300, 0.5]}), "not a finite number within ±1000"),
    ],
    ids=[
        "empty",
        "not-json",
        "not-an-object",
        "future-version",
        "short-neutral",
        "null-value",
        "bad-mesh",
        "unknown-feature",
        "bad-range",
        "unknown-field",
        "other-format",
        "huge-frame",
        "huge-range",
    ],
)
def test_broken_state_files_are_refused_with_the_reason(data: bytes, detail: str) -> None:
    with pytest.raises(StateError) as info:
        parse_state(data, "s.json")
    assert str(info.value).startswith("s.json") or detail in str(info.value)
    assert detail in str(info.value)


@pytest.mark.parametrize("name", ["", "..", "../x", "a/b", ".hidden", "x" * 65, "sp ace"])
def test_names_that_are_not_plain_file_names_are_refused(name: str) -> None:
    with pytest.raises(StateError, match="cannot name a state file"):
        check_name(name, "performer")


# --- the service: restart, relearn, logging -------------------------------------------------------


async def run_features(processor: FeatureProcessor, keeping: StateKeeping, frames: list) -> list:
    async with StageRun(
        lambda ctx: serve_features(ctx, processor, 64, keeping), service="features", rig="lab"
    ) as run:
        for points in frames:
            await run.send("points", points)
            await run.advance(1 / FPS)
        return run.messages("features")


async def test_a_restarted_features_service_picks_up_its_neutral(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    keeping = StateKeeping(performer="alice", state_dir=str(tmp_path))
    caplog.set_level(logging.INFO, "facesynth")
    first = await run_features(FeatureProcessor(), keeping, neutral_then(MESH, 40))
    assert (tmp_path / "lab" / "alice.json").is_file()
    assert "learned the neutral of performer alice: saved to" in caplog.text
    # Restarted while the performer holds a raised brow: the kept neutral, not this face.
    second = await run_features(FeatureProcessor(), keeping, neutral_then(RAISED, 5, start=200))
    assert "restored the neutral and ranges of performer alice on rig lab" in caplog.text
    assert all(f.neutral_ready for f in second)
    assert second[0].named["brow_raise_inner_right"] > 0.3
    assert first[-1].named["brow_raise_inner_right"] == pytest.approx(0.0, abs=0.02)


async def test_reusing_and_saving_the_neutral_are_each_one_line_with_where_and_how_old(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """A neutral kept from an earlier run is never reused silently (issue 29)."""
    keeping = StateKeeping(performer="alice", state_dir=str(tmp_path))
    path = tmp_path / "lab" / "alice.json"
    caplog.set_level(logging.INFO, "facesynth")
    await run_features(FeatureProcessor(), keeping, neutral_then(MESH, 40))
    saved = [r.getMessage() for r in caplog.records if "saved to" in r.getMessage()]
    assert saved == [f"learned the neutral of performer alice: saved to {path}"]
    kept = load_state(path)
    assert kept is not None  # learned three hours before the next start (the fake clock's 0)
    path.write_bytes(
        msgspec.json.encode(msgspec.structs.replace(kept, updated_ns=FAKE_EPOCH_NS - 3 * 3600 * S))
    )
    caplog.clear()
    await run_features(FeatureProcessor(), keeping, neutral_then(RAISED, 5, start=200))
    reused = [r.getMessage() for r in caplog.records if "restored" in r.getMessage()]
    assert reused == [
        f"restored the neutral and ranges of performer alice on rig lab from {path} (3 h old)"
    ]


async def test_relearn_ignores_the_kept_neutral_and_replaces_it(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, "facesynth")
    await run_features(
        FeatureProcessor(), StateKeeping("alice", str(tmp_path)), neutral_then(MESH, 40)
    )
    before = load_state(tmp_path / "lab" / "alice.json")
    relearn = StateKeeping("alice", str(tmp_path), relearn=True)
    out = await run_features(FeatureProcessor(), relearn, neutral_then(RAISED, 40, start=300))
    assert "--relearn: learning the neutral of alice afresh" in caplog.text
    assert not out[0].neutral_ready and out[-1].neutral_ready
    after = load_state(tmp_path / "lab" / "alice.json")
    assert before is not None and after is not None and after.neutral != before.neutral


async def test_a_broken_state_file_is_said_and_replaced(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    path = tmp_path / "lab" / "alice.json"
    path.parent.mkdir(parents=True)
    path.write_bytes(b'{"format": "facesynth.features.state", "version": 1, "rig": ')  # torn
    caplog.set_level(logging.INFO, "facesynth")
    out = await run_features(
        FeatureProcessor(), StateKeeping("alice", str(tmp_path)), neutral_then(MESH, 40)
    )
    assert "cannot use the learned state" in caplog.text and "learning afresh" in caplog.text
    assert out[-1].neutral_ready
    assert isinstance(load_state(path), LearnedState)


async def test_auto_range_saves_as_the_neutral_moves_and_logs_each_save(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, "facesynth")
    frames = neutral_then(MESH, 40) + neutral_then(RAISED, 30 * 25, start=40)
    await run_features(
        FeatureProcessor(auto_range=True), StateKeeping("bob", str(tmp_path)), frames
    )
    saves = caplog.text.count("auto range: neutral and ranges of performer bob updated")
    assert saves >= 2  # the rolling neutral moved to the raised brow: saved every 10 s
    kept = load_state(tmp_path / "lab" / "bob.json")
    fresh = learned_processor(auto=True)
    assert kept is not None and kept.named_neutral != snapshot(fresh, "lab", "bob", 0).named_neutral
