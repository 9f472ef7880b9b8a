"""A closed loop's state kept beside its learned profile: written atomically, read back the
same, and every malformed file a one-line error."""

from __future__ import annotations

import re
from pathlib import Path

import msgspec
import numpy as np
import pytest
from test_translator_closed_loop import closed_profile

from facesynth.runtime.profiles import Profile
from facesynth.runtime.profiles.learned import pack
from facesynth.services.translator.closed_loop import LoopOptions, LoopState
from facesynth.services.translator.core import Translator
from facesynth.services.translator.loop_state import (
    LoopStateError,
    decode_loop_state,
    encode_loop_state,
    load_loop_state,
    loop_state_path,
    save_loop_state,
)


@pytest.fixture(scope="module")
def profile() -> Profile:
    return closed_profile()


def learned_state(profile: Profile) -> LoopState:
    assert profile.learned is not None
    n_in, n_out = len(profile.learned.inputs), len(profile.learned.outputs)
    rng = np.random.default_rng(1)
    covariance = np.diag(rng.uniform(0.01, 1.0, n_out + 1))
    return LoopState(weights=rng.normal(size=(n_in, n_out + 1)), covariance=covariance, updates=17)


def test_the_state_is_kept_beside_the_profile() -> None:
    assert loop_state_path("runs/head.learned") == Path("runs/head.loop")


def test_a_saved_state_loads_back_the_same(tmp_path: Path, profile: Profile) -> None:
    assert profile.learned is not None
    state = learned_state(profile)
    path = save_loop_state(state, profile.name, profile.learned, tmp_path / "head.loop")
    loaded = load_loop_state(path, profile.learned)
    assert loaded is not None
    assert np.array_equal(loaded.weights, state.weights)
    assert np.array_equal(loaded.covariance, state.covariance)
    assert loaded.updates == 17
    assert [p.name for p in tmp_path.iterdir()] == ["head.loop"]  # no temporary file left


def test_a_translator_continues_from_a_saved_state(profile: Profile) -> None:
    state = learned_state(profile)
    loop = Translator(profile).close_loop(LoopOptions(), state)
    assert loop.state is state


def test_no_file_yet_is_no_state(tmp_path: Path, profile: Profile) -> None:
    assert profile.learned is not None
    assert load_loop_state(tmp_path / "none.loop", profile.learned) is None


def _tree(profile: Profile) -> dict[str, object]:
    assert profile.learned is not None
    data = encode_loop_state(learned_state(profile), profile.name, profile.learned)
    tree: dict[str, object] = msgspec.msgpack.decode(data)
    return tree


def _broken(profile: Profile, change: str) -> bytes:
    assert profile.learned is not None
    tree = _tree(profile)
    n_out = len(profile.learned.outputs)
    if change == "format":
        tree["format"] = "facesynth.learned_profile"
    elif change == "version":
        tree["version"] = 2
    elif change == "inputs":
        tree["inputs"] = ["jaw_open"]
    elif change == "outputs":
        tree["outputs"] = list(reversed(profile.learned.outputs))
    elif change == "shape":
        tree["covariance"] = msgspec.structs.asdict(pack(np.eye(n_out)))
    elif change == "nan":
        weights = np.zeros((len(profile.learned.inputs), n_out + 1))
        weights[0, 0] = np.nan
        tree["weights"] = msgspec.structs.asdict(pack(weights))
    elif change == "asymmetric":
        covariance = np.eye(n_out + 1)
        covariance[0, 1] = 5.0
        tree["covariance"] = msgspec.structs.asdict(pack(covariance))
    elif change == "huge":
        tree["covariance"] = msgspec.structs.asdict(pack(np.eye(n_out + 1) * 1e300))
    elif change == "updates":
        tree["updates"] = -1
    elif change == "unknown":
        tree["extra"] = 1
    elif change == "missing":
        del tree["weights"]
    elif change == "newline":
        tree["\n"] = 1  # a key the error quotes
    return msgspec.msgpack.encode(tree)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ("format", "format 'facesynth.learned_profile' is not 'facesynth.closed_loop'"),
        ("version", "version 2 is not supported"),
        ("inputs", "learned for other models"),
        ("outputs", "learned for other models"),
        ("shape", "covariance: shape"),
        ("nan", "weights: holds values that are not finite"),
        ("asymmetric", "covariance is not symmetric"),
        ("huge", "covariance: holds values beyond ±1e+06"),
        ("updates", "updates -1 is negative"),
        ("unknown", "not a closed-loop state file"),
        ("missing", "not a closed-loop state file"),
        ("newline", "unknown field `\\n`"),
    ],
)
def test_a_malformed_state_is_one_line(profile: Profile, change: str, message: str) -> None:
    assert profile.learned is not None
    with pytest.raises(LoopStateError, match=re.escape(message)) as info:
        decode_loop_state(_broken(profile, change), profile.learned)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("data", [b"", b"\x00\x01garbage", b"\x93\x01\x02\x03"])
def test_a_file_that_is_no_state_names_itself(
    tmp_path: Path, profile: Profile, data: bytes
) -> None:
    assert profile.learned is not None
    path = tmp_path / "head.loop"
    path.write_bytes(data)
    with pytest.raises(LoopStateError, match=f"loop state {path}: not a closed-loop state") as info:
        load_loop_state(path, profile.learned)
    assert "\n" not in str(info.value)


def test_an_unreadable_state_is_one_line(tmp_path: Path, profile: Profile) -> None:
    assert profile.learned is not None
    with pytest.raises(LoopStateError, match=f"loop state {tmp_path}: ") as info:
        load_loop_state(tmp_path, profile.learned)  # a folder
    assert "\n" not in str(info.value)
