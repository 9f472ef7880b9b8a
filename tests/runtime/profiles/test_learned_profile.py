"""Learned profile files (NAME.learned): lookup, round trip, and every malformed variant."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import msgspec
import numpy as np
import pytest
from learned_fixtures import INPUTS, knn_learned, learned_profile

from facesynth.runtime.profiles import (
    PACKAGE_DIR,
    ProfileError,
    available_profiles,
    describe_learned,
    encode_learned_profile,
    load_profile,
    parse_learned_profile,
    parse_profile,
    save_learned_profile,
)
from facesynth.runtime.profiles.learned import Retarget, command_range, pack
from facesynth.runtime.profiles.learned_predict import ACTIVATIONS, predictor


def _document(**changes: Any) -> dict[str, Any]:
    """The file as plain msgpack data, with ``changes`` at the top level."""
    document = msgspec.msgpack.decode(encode_learned_profile(learned_profile()))
    document.update(changes)
    return document


def _bytes(document: dict[str, Any]) -> bytes:
    return msgspec.msgpack.encode(document)


def test_round_trip_and_lookup(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    profile = learned_profile()
    path = save_learned_profile(profile, tmp_path / "robot.learned")
    assert path.read_bytes()[:1] != b"\x80"  # a msgpack map, not pickle
    assert load_profile(str(path)) == profile
    monkeypatch.setenv("FACESYNTH_PROFILES", str(tmp_path))
    assert load_profile("robot") == profile
    assert "robot" in available_profiles() and "head16_hardware" in available_profiles(
        hardware=True
    )
    assert "head16_hardware" not in available_profiles()  # a chain cannot run it (T refuses)
    # A written profile of the same name in the same folder comes first.
    (tmp_path / "robot.toml").write_text((PACKAGE_DIR / "head16_hardware.toml").read_text())
    assert load_profile("robot").learned is None
    assert "learned: poly_ridge from 3 inputs to 3 servos (1 dead)" in describe_learned(
        profile.learned
    )


def test_responsive_ranges_round_trip_and_default_to_the_whole_travel(tmp_path: Path) -> None:
    profile = learned_profile()
    assert profile.learned.command_low is None  # a file without them is valid: [-1, 1]
    older = {k: v for k, v in _document().items() if k not in ("command_low", "command_high")}
    assert parse_learned_profile(_bytes(older), "old.learned") == profile
    low, high = command_range(profile.learned)
    assert low.tolist() == [-1.0] * 3 and high.tolist() == [1.0] * 3
    learned = msgspec.structs.replace(
        profile.learned,
        command_low=pack(np.array([-1.0, 0.0, -0.5])),
        command_high=pack(np.array([0.0, 1.0, 0.5]), "<f4"),
        report=msgspec.structs.replace(
            profile.learned.report,
            servo_error={"right_eyebrow": 0.2},
            effective_error={"right_eyebrow": 0.04},
        ),
    )
    profile = msgspec.structs.replace(profile, learned=learned)
    loaded = load_profile(str(save_learned_profile(profile, tmp_path / "r.learned")))
    assert loaded == profile
    low, high = command_range(loaded.learned)
    assert low.tolist() == [-1.0, 0.0, -0.5] and high.tolist() == [0.0, 1.0, 0.5]
    text = describe_learned(loaded.learned)
    assert "held-out error 0.200" in text and "effective 0.040" in text


def test_retargeting_round_trips_and_a_version_1_file_loads_without_it(tmp_path: Path) -> None:
    profile = learned_profile()
    assert profile.learned.retarget is None and profile.learned.noise is None
    retargeted = msgspec.structs.replace(
        profile,
        learned=msgspec.structs.replace(
            profile.learned, noise=pack(np.full(3, 0.001)), retarget=Retarget(gain=0.8)
        ),
    )
    path = save_learned_profile(retargeted, tmp_path / "new.learned")
    assert msgspec.msgpack.decode(path.read_bytes())["version"] == 3
    assert load_profile(str(path)) == retargeted
    assert "retargets 0.8 of the performer's change into the robot's reach over the 3 inputs" in (
        describe_learned(retargeted.learned)
    )
    assert "retargets" not in describe_learned(profile.learned)
    # a file written before version 2: no noise, no retarget, version 1
    old = _document(version=1)
    del old["noise"], old["retarget"]
    (tmp_path / "old.learned").write_bytes(_bytes(old))
    assert load_profile(str(tmp_path / "old.learned")) == profile


def test_knn_and_float32_arrays_round_trip(tmp_path: Path) -> None:
    profile = learned_profile()
    names = [s.name for s in profile.servos]
    profile = msgspec.structs.replace(profile, learned=knn_learned(names[:3], names[3:]))
    loaded = parse_learned_profile(encode_learned_profile(profile), "k.learned")
    assert loaded == profile
    out = predictor(loaded.learned.inverse)(np.zeros((2, len(INPUTS))))
    assert out.shape == (2, 3)


def test_missing_learned_file_and_learned_in_toml(tmp_path: Path) -> None:
    with pytest.raises(ProfileError, match=r"profile file /nowhere/robot\.learned does not exist"):
        load_profile("/nowhere/robot.learned")
    with pytest.raises(ProfileError, match="no profile named 'robot9'"):
        load_profile("robot9")
    text = 'name = "x"\n[learned]\ninputs = []\n[[servos]]\nname = "a"\nchannel = 0\n'
    text += "min_us = 1000\nneutral_us = 1500\nmax_us = 2000\n"
    with pytest.raises(ProfileError, match="learned: only a learned profile file"):
        parse_profile(text, "x.toml")


def test_hardware_profile_is_valid() -> None:
    profile = load_profile("head16_hardware")
    assert len(profile.servos) == 16 and profile.learned is None
    paper16 = load_profile("paper16")
    for spec, paper in zip(profile.servos, paper16.servos, strict=True):
        assert (spec.name, spec.channel, spec.min_us, spec.neutral_us, spec.max_us) == (
            paper.name,
            paper.channel,
            paper.min_us,
            paper.neutral_us,
            paper.max_us,
        )
        assert (spec.max_speed, spec.max_accel) == (paper.max_speed, paper.max_accel)
        assert not spec.points and spec.weights() is None


def _inverse(**changes: Any) -> dict[str, Any]:
    inverse = _document()["inverse"]
    inverse.update(changes)
    return inverse


def _array(values: Any, dtype: str = "<f8") -> dict[str, Any]:
    array = pack(np.asarray(values, dtype=np.float64), dtype)
    return msgspec.to_builtins(array, builtin_types=(bytes,))  # type: ignore[no-any-return]


def _knn(**changes: Any) -> dict[str, Any]:
    learned = knn_learned(["right_eyebrow", "left_eyebrow", "middle_eyebrow"], ["right_eye_x"])
    inverse = msgspec.to_builtins(learned.inverse, builtin_types=(bytes,))
    inverse.update(changes)
    return inverse  # type: ignore[no-any-return]


def _mapping() -> dict[str, Any]:
    document = _document()
    return {k: v for k, v in document.items() if k not in ("format", "version", "profile")}


GOOD = encode_learned_profile(learned_profile())
NAN = _array([np.nan, 0.1, 0.1])
NAN["data"] = np.array([np.nan, 0.1, 0.1]).tobytes()

MALFORMED = [
    ("truncated", GOOD[: len(GOOD) // 2], "not msgpack: Input data was truncated"),
    ("not msgpack", b"\xc1 this is not msgpack", "not a learned profile (not msgpack"),
    ("empty", b"", "not msgpack"),
    ("a toml file", b'name = "robot"\n', "not a learned profile"),
    ("a list", _bytes([1, 2]), "not a learned profile (Expected `object`"),
    ("wrong format", _bytes(_document(format="facesynth.calibration")), "format 'facesynth.calib"),
    ("no format", _bytes({"version": 1}), "format None"),
    ("wrong version", _bytes(_document(version=4)), "version 4 is not supported (this reads 1, 2"),
    ("version true", _bytes(_document(version=True)), "version True is not supported"),
    ("noise shape", _bytes(_document(noise=_array([0.1, 0.1]))), "noise: shape [2] is not [3]"),
    ("noise sign", _bytes(_document(noise=_array([0.1, -0.1, 0]))), "noise: must be >= 0"),
    ("noise nan", _bytes(_document(noise=NAN)), "noise: holds values that are not finite"),
    ("retarget gain", _bytes(_document(retarget={"gain": 0.0})), "retarget.gain 0.0 is outside"),
    ("retarget tau", _bytes(_document(retarget={"tau_s": float("inf")})), "retarget.tau_s inf"),
    ("retarget weight", _bytes(_document(retarget={"min_weight": 2})), "retarget.min_weight 2"),
    ("retarget region", _bytes(_document(retarget={"region_floor": 0})), "retarget.region_floor"),
    ("retarget extent", _bytes(_document(retarget={"extent": -2.5})), "retarget.extent -2.5"),
    ("retarget show", _bytes(_document(retarget={"show_noise": -1})), "retarget.show_noise -1"),
    ("retarget lead", _bytes(_document(retarget={"lead_s": -0.1})), "retarget.lead_s -0.1 is"),
    ("retarget lead nan", _bytes(_document(retarget={"lead_s": float("nan")})), "lead_s nan is"),
    ("retarget lead long", _bytes(_document(retarget={"lead_s": 2})), "lead_s 2.0 is outside"),
    ("retarget field", _bytes(_document(retarget={"boost": 2})), "unknown field `boost`"),
    ("retarget type", _bytes(_document(retarget=[0.9])), "`$.retarget`"),
    # Found by fuzzing: msgspec raises UnicodeDecodeError for a string that is not UTF-8.
    (
        "format not utf-8",
        _bytes(_document(format="\u00ff")).replace(b"\xc3\xbf", b"\xff\xff"),
        "not msgpack: 'utf-8' codec can't decode byte 0xff",
    ),
    (
        "servo name not utf-8",
        _bytes(_document(dead=["right_eye_\u00ff"])).replace(b"\xc3\xbf", b"\xff\xff"),
        "malformed learned profile: 'utf-8' codec can't decode byte 0xff",
    ),
    ("unknown model", _bytes(_document(inverse=_inverse(kind="forest"))), "`$.inverse.kind`"),
    ("unknown field", _bytes(_document(wheels=4)), "unknown field `wheels`"),
    (
        "missing field",
        _bytes({k: v for k, v in _document().items() if k != "outputs"}),
        "`outputs`",
    ),
    (
        "coef shape",
        _bytes(_document(inverse=_inverse(coef=_array(np.zeros((2, 3)))))),
        "inverse: coef [2, 3] / intercept [3] do not fit 3 outputs of 3 terms",
    ),
    (
        "bytes short",
        _bytes(_document(reach_low={"dtype": "<f8", "shape": [3], "data": b"\0" * 20})),
        "reach_low: holds 20 bytes, shape [3] needs 24",
    ),
    ("nan", _bytes(_document(input_mean=NAN)), "input_mean: holds values that are not finite"),
    ("dtype", _bytes(_document(input_scale=_array([1, 1, 1], "<i4"))), "dtype '<i4'"),
    ("reach shape", _bytes(_document(reach_high=_array([0.1, 0.1]))), "shape [2] is not [3]"),
    ("reach sign", _bytes(_document(reach_low=_array([0.1, 0, 0]))), "reach_low <= 0"),
    ("scale", _bytes(_document(input_scale=_array([1, 0, 1]))), "input_scale must be > 0"),
    ("unknown input", _bytes(_document(inputs=["jaw_open", "wings", "x"])), "not features"),
    ("servo twice", _bytes(_document(dead=["right_eyebrow"])), "both in outputs and dead"),
    ("servo missing", _bytes(_document(dead=[])), "missing ['right_eye_x']"),
    ("unknown servo", _bytes(_document(dead=["tail"])), "unknown ['tail']"),
    (
        "forward shape",
        _bytes(
            _document(
                forward={
                    "kind": "mlp",
                    "activation": "relu",
                    "layers": [{"weights": _array(np.ones((2, 3))), "bias": _array([0, 0, 0])}],
                }
            )
        ),
        "forward: layers[0]: weights [2, 3] / bias [3] do not follow 3 inputs",
    ),
    (
        "activation",
        _bytes(_document(forward={"kind": "mlp", "activation": "swish", "layers": []})),
        "activation 'swish'",
    ),
    ("plan steps", _bytes(_document(plan_steps=99, forward=None)), "plan_steps must be from"),
    ("plan prior", _bytes(_document(plan_prior=-1.0)), "plan_prior must be a finite number"),
    ("plan prior nan", _bytes(_document(plan_prior=float("nan"))), "plan_prior must be a fin"),
    ("plan without poly", _bytes(_document(plan_steps=3)), "plan_steps needs a poly_ridge"),
    ("plan no forward", _bytes(_document(plan_steps=3, forward=None)), "needs a poly_ridge"),
    ("low shape", _bytes(_document(command_low=_array([-1, -1]))), "command_low: shape [2] is not"),
    ("high nan", _bytes(_document(command_high=NAN)), "command_high: holds values that are not"),
    ("low above 0", _bytes(_document(command_low=_array([-1, 0.2, 0]))), "-1 <= command_low <= 0"),
    ("high below 0", _bytes(_document(command_high=_array([1, -0.1, 1]))), "<= command_high <= 1"),
    ("high above 1", _bytes(_document(command_high=_array([1, 1.5, 1]))), "<= command_high <= 1"),
    ("low below -1", _bytes(_document(command_low=_array([-2, 0, 0]))), "-1 <= command_low"),
    ("low dtype", _bytes(_document(command_low=_array([-1, 0, 0], "<i4"))), "command_low: dtype"),
    ("knn k", _bytes(_document(inverse=_knn(k=99))), "inverse: k 99 is outside 1..30"),
    ("knn weights", _bytes(_document(inverse=_knn(weights="gauss"))), "weights 'gauss'"),
    (
        "powers",
        _bytes(_document(inverse=_inverse(powers=_array(np.eye(3) * 3)))),
        "more than the degree",
    ),
    (
        "bad profile",
        _bytes(_document(profile={**_document()["profile"], "servos": []})),
        "no servos",
    ),
    (
        "nested learned",
        _bytes(_document(profile={**_document()["profile"], "learned": _mapping()})),
        "profile.learned: the hardware profile holds no mapping",
    ),
]


@pytest.mark.parametrize(
    ("data", "detail"), [m[1:] for m in MALFORMED], ids=[m[0] for m in MALFORMED]
)
def test_malformed_files_are_one_profile_error(data: bytes, detail: str, tmp_path: Path) -> None:
    path = tmp_path / "robot.learned"
    path.write_bytes(data)
    with pytest.raises(ProfileError) as info:
        load_profile(str(path))
    message = str(info.value)
    assert message.startswith(f"{path}: ")
    assert "\n" not in message
    assert detail in message


@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_huge_powers_are_refused_without_overflowing(tmp_path: Path) -> None:
    """Found by the fuzz suite: powers near the largest float overflowed their sum (a numpy
    warning) before the file was refused; each power is now held against the degree first."""
    huge = _array(np.full((3, 3), np.finfo(np.float64).max))
    path = tmp_path / "robot.learned"
    path.write_bytes(_bytes(_document(inverse=_inverse(powers=huge))))
    with pytest.raises(ProfileError, match="a term's powers add up to more than the degree 1"):
        load_profile(str(path))


def test_every_activation_a_file_may_name_runs() -> None:
    from facesynth.runtime.profiles.learned import ACTIVATION_NAMES

    assert tuple(ACTIVATIONS) == ACTIVATION_NAMES
