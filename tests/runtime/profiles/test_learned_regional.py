"""A regional inverse model in a learned profile (file version 3): one model per region of the
face, each reading its own inputs; round trip, its numpy prediction, the older versions still
loading, and every malformed variant a one-line ProfileError."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import msgspec
import numpy as np
import pytest
from learned_fixtures import INPUTS, learned_profile

from facesynth.runtime.profiles import (
    ProfileError,
    encode_learned_profile,
    load_profile,
    save_learned_profile,
)
from facesynth.runtime.profiles.learned import KNN, Part, PolyRidge, Regional, pack
from facesynth.runtime.profiles.learned_predict import predictor

#: The fixture's outputs: right_eyebrow, left_eyebrow, middle_eyebrow (right_eye_x dead).
BROWS = PolyRidge(
    degree=1,
    powers=pack(np.eye(2)),
    coef=pack(np.array([[1.0, 0.5], [0.0, -2.0]])),
    intercept=pack(np.array([0.1, 0.0])),
)
TRAIN_X = np.array([[0.0], [1.0], [2.0], [3.0]])
MIDDLE = KNN(k=1, weights="uniform", train_x=pack(TRAIN_X), train_y=pack(TRAIN_X * 0.3))
#: right and middle brows from inputs 0 and 2 (the ridge), the left one from input 1 (knn).
REGIONAL = Regional(
    parts=[
        Part(inputs=[0, 2], outputs=[0, 2], model=BROWS),
        Part(inputs=[1], outputs=[1], model=MIDDLE),
    ]
)


def _regional_profile() -> Any:
    profile = learned_profile()
    return msgspec.structs.replace(
        profile, learned=msgspec.structs.replace(profile.learned, inverse=REGIONAL)
    )


def test_a_regional_model_round_trips_and_each_part_reads_only_its_inputs(tmp_path: Path) -> None:
    profile = _regional_profile()
    path = save_learned_profile(profile, tmp_path / "robot.learned")
    assert msgspec.msgpack.decode(path.read_bytes())["version"] == 3
    loaded = load_profile(str(path))
    assert loaded == profile
    predict = predictor(loaded.learned.inverse)
    x = np.array([[1.0, 2.0, 3.0], [0.0, 0.4, -1.0]])
    out = predict(x)
    assert out.shape == (2, 3)
    np.testing.assert_allclose(out[:, 0], 0.1 + x[:, 0] + 0.5 * x[:, 2])
    np.testing.assert_allclose(out[:, 2], -2.0 * x[:, 2])
    np.testing.assert_allclose(out[:, 1], [0.6, 0.0])  # nearest of 0..3 to 2.0 and 0.4, × 0.3
    # the left brow's part never reads inputs 0 and 2: changing them leaves its command
    moved = x.copy()
    moved[:, [0, 2]] += 5.0
    np.testing.assert_array_equal(predict(moved)[:, 1], out[:, 1])
    assert INPUTS[1] == loaded.learned.inputs[1]


def test_files_of_the_older_versions_still_load(tmp_path: Path) -> None:
    for version in (1, 2):
        document = msgspec.msgpack.decode(encode_learned_profile(learned_profile()))
        document["version"] = version
        if version == 1:
            del document["noise"], document["retarget"]
        path = tmp_path / f"v{version}.learned"
        path.write_bytes(msgspec.msgpack.encode(document))
        assert load_profile(str(path)) == learned_profile()


def _document(**changes: Any) -> dict[str, Any]:
    document = msgspec.msgpack.decode(encode_learned_profile(_regional_profile()))
    document.update(changes)
    return document


def _parts(*changes: dict[str, Any]) -> dict[str, Any]:
    """The regional inverse with each part updated by the change at its index."""
    inverse = _document()["inverse"]
    for part, change in zip(inverse["parts"], changes, strict=False):
        part.update(change)
    return inverse  # type: ignore[no-any-return]


def _bytes(document: dict[str, Any]) -> bytes:
    return msgspec.msgpack.encode(document)


MALFORMED = [
    ("regional in version 2", _document(version=2), "regional model needs version 3 (not 2)"),
    ("no parts", _document(inverse={"kind": "regional", "parts": []}), "at least one part"),
    ("empty inputs", _document(inverse=_parts({"inputs": []})), "parts[0]: inputs is empty"),
    ("input out of range", _document(inverse=_parts({"inputs": [0, 3]})), "indices below 3"),
    ("input twice", _document(inverse=_parts({"inputs": [2, 2]})), "are not distinct indices"),
    ("negative output", _document(inverse=_parts({}, {"outputs": [-1]})), "parts[1]: outputs"),
    ("empty outputs", _document(inverse=_parts({}, {"outputs": []})), "outputs is empty"),
    (
        "output given twice",
        _document(inverse=_parts({}, {"outputs": [0]})),
        "inverse: the parts must give each of the 3 outputs once",
    ),
    (
        "output missing",
        _document(inverse=_parts({"outputs": [0, 2]}, {"inputs": [1], "outputs": [2]})),
        "the parts must give each of the 3 outputs once",
    ),
    (
        "part model shape",
        _document(inverse=_parts({"inputs": [0, 1, 2]})),
        "inverse.parts[0].model: powers shape [2, 2] is not (terms, 3)",
    ),
    (
        "part model k",
        _document(inverse=_parts({}, {"model": {**_parts()["parts"][1]["model"], "k": 9}})),
        "inverse.parts[1].model: k 9 is outside 1..4",
    ),
    ("nested regional", _document(inverse=_parts({"model": _parts()})), "parts[0].model"),
    ("part field", _document(inverse=_parts({"weight": 1})), "unknown field `weight`"),
    (
        "regional forward",
        _document(forward=_parts()),
        "forward: a regional model is for the inverse only",
    ),
]


@pytest.mark.parametrize(
    ("document", "detail"), [m[1:] for m in MALFORMED], ids=[m[0] for m in MALFORMED]
)
def test_malformed_regional_files_are_one_profile_error(
    document: dict[str, Any], detail: str, tmp_path: Path
) -> None:
    path = tmp_path / "robot.learned"
    path.write_bytes(_bytes(document))
    with pytest.raises(ProfileError) as info:
        load_profile(str(path))
    message = str(info.value)
    assert message.startswith(f"{path}: ")
    assert "\n" not in message
    assert detail in message
