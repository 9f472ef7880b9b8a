"""facesynth.runtime.keys: key expressions, name checks, and the stage wiring of the chain."""

from __future__ import annotations

import pytest
import zenoh

from facesynth.runtime import keys
from facesynth.runtime.keys import KeyNameError


@pytest.mark.parametrize(
    "name",
    ["default", "rig-1", "lab_2.b", "A", "x" * 64, "0"],
    ids=["word", "dash", "underscore-dot", "one-char", "64-chars", "digit"],
)
def test_valid_names_pass(name: str) -> None:
    assert keys.check_name(name) == name


@pytest.mark.parametrize(
    "name",
    ["", "a/b", "a*", "**", "a b", "x" * 65, "rig$", "é", "a\n", "$*"],
    ids=[
        "empty",
        "slash",
        "star",
        "double-star",
        "space",
        "65-chars",
        "dollar",
        "non-ascii",
        "newline",
        "zenoh-wild",
    ],
)
def test_invalid_names_fail_with_reason(name: str) -> None:
    with pytest.raises(KeyNameError) as info:
        keys.check_name(name, "instance")
    text = str(info.value)
    assert f"invalid instance name {name!r}" in text
    assert "1-64 letters" in text


@pytest.mark.parametrize(
    ("stage", "key"),
    [
        ("input", "facesynth/lab/input"),
        ("points", "facesynth/lab/points"),
        ("features", "facesynth/lab/features"),
        ("servo_commands", "facesynth/lab/servo_commands"),
    ],
    ids=["input", "points", "features", "servo_commands"],
)
def test_stage_keys(stage: keys.Stage, key: str) -> None:
    assert keys.stage_key("lab", stage) == key


def test_unknown_stage_lists_known_stages() -> None:
    with pytest.raises(KeyNameError, match="unknown stage 'commands'; known: input, points"):
        keys.stage_key("lab", "commands")  # type: ignore[arg-type]


def test_stage_key_checks_the_rig() -> None:
    with pytest.raises(KeyNameError, match="invalid rig name 'a/b'"):
        keys.stage_key("a/b", "input")


def test_health_and_stats_keys() -> None:
    assert keys.health_key("lab", "features", "i-1") == "facesynth/lab/health/features/i-1"
    assert keys.stats_key("lab", "control", "i-2") == "facesynth/lab/stats/control/i-2"


@pytest.mark.parametrize(
    ("func", "args", "what"),
    [
        (keys.health_key, ("lab", "fea/tures", "i"), "service"),
        (keys.health_key, ("lab", "features", "*"), "instance"),
        (keys.stats_key, ("l b", "features", "i"), "rig"),
        (keys.stats_key, ("lab", "features", ""), "instance"),
    ],
    ids=["health-service", "health-instance", "stats-rig", "stats-instance"],
)
def test_service_keys_check_every_chunk(func, args, what: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(KeyNameError, match=f"invalid {what} name"):
        func(*args)


@pytest.mark.parametrize(
    ("func", "rig", "pattern"),
    [
        (keys.health_pattern, None, "facesynth/*/health/**"),
        (keys.health_pattern, "lab", "facesynth/lab/health/**"),
        (keys.stats_pattern, None, "facesynth/*/stats/**"),
        (keys.stats_pattern, "lab", "facesynth/lab/stats/**"),
    ],
    ids=["health-all", "health-rig", "stats-all", "stats-rig"],
)
def test_patterns(func, rig: str | None, pattern: str) -> None:  # type: ignore[no-untyped-def]
    assert func(rig) == pattern


def test_pattern_checks_the_rig() -> None:
    with pytest.raises(KeyNameError):
        keys.health_pattern("a/b")


@pytest.mark.parametrize(
    ("key", "parsed"),
    [
        ("facesynth/lab/health/features/i-1", ("lab", "features", "i-1")),
        ("facesynth/lab/stats/control/i-2", ("lab", "control", "i-2")),
        ("facesynth/lab/points", None),
        ("facesynth/lab/health/features", None),
        ("facesynth/lab/health/features/i/extra", None),
        ("other/lab/health/features/i", None),
        ("facesynth/lab/status/features/i", None),
    ],
    ids=["health", "stats", "data-key", "too-short", "too-long", "other-prefix", "other-kind"],
)
def test_parse_service_key(key: str, parsed: tuple[str, str, str] | None) -> None:
    assert keys.parse_service_key(key) == parsed


def test_parse_inverts_the_builders() -> None:
    for build in (keys.health_key, keys.stats_key):
        assert keys.parse_service_key(build("r", "translator", "x.1")) == ("r", "translator", "x.1")


def test_the_chain_is_wired_end_to_end() -> None:
    # S -> P -> F -> T -> C: each service consumes exactly what the one before it publishes.
    assert keys.SERVICES == ("sensor", "points", "features", "translator", "control")
    assert set(keys.PUBLISHES) == set(keys.CONSUMES) == set(keys.SERVICES)
    assert keys.CONSUMES["sensor"] is None
    # C publishes what it applied, which nobody in the chain consumes (monitors, flow control).
    assert keys.PUBLISHES["control"] == "servo_state"
    assert "servo_state" not in keys.CONSUMES.values()
    for before, after in zip(keys.SERVICES, keys.SERVICES[1:], strict=False):
        assert keys.PUBLISHES[before] == keys.CONSUMES[after]
        assert keys.PUBLISHES[before] in keys.STAGES
    published = [s for s in keys.PUBLISHES.values() if s is not None]
    assert published == list(keys.STAGES)


def test_a_robot_has_its_own_command_and_state_keys() -> None:
    assert keys.stage_key("lab", "servo_commands", "head1") == "facesynth/lab/servo_commands/head1"
    assert keys.stage_key("lab", "servo_state", "head1") == "facesynth/lab/servo_state/head1"
    # Without a robot the single-robot keys stay as they were.
    assert keys.stage_key("lab", "servo_commands") == "facesynth/lab/servo_commands"
    assert keys.stage_key("lab", "servo_state", None) == "facesynth/lab/servo_state"
    assert keys.stage_key("lab", "servo_state", "") == "facesynth/lab/servo_state"


@pytest.mark.parametrize("stage", ["input", "points", "features"])
def test_the_performer_stages_are_shared_by_every_robot(stage: keys.Stage) -> None:
    with pytest.raises(KeyNameError, match="shared by every robot"):
        keys.stage_key("lab", stage, "head1")


@pytest.mark.parametrize("robot", ["a/b", "*", "**", "x" * 65, "r 1"])
def test_bad_robot_names_are_refused(robot: str) -> None:
    with pytest.raises(KeyNameError, match="invalid robot name"):
        keys.stage_key("lab", "servo_commands", robot)


def test_robots_pattern_matches_the_single_key_and_every_robot_but_nothing_else() -> None:
    pattern = zenoh.KeyExpr(keys.robots_pattern("lab", "servo_state"))
    for key in ("facesynth/lab/servo_state", "facesynth/lab/servo_state/r00"):
        assert pattern.intersects(zenoh.KeyExpr(key)), key
    for key in ("facesynth/lab/servo_commands/r00", "facesynth/other/servo_state/r00"):
        assert not pattern.intersects(zenoh.KeyExpr(key)), key
    # The performer's stages have no robot keys: their pattern is the key itself.
    assert keys.robots_pattern("lab", "features") == "facesynth/lab/features"


def test_robot_of_reads_the_robot_of_a_robot_key_only() -> None:
    assert keys.robot_of("facesynth/lab/servo_commands/head1") == "head1"
    assert keys.robot_of("facesynth/lab/servo_state/r07") == "r07"
    assert keys.robot_of("facesynth/lab/servo_state") is None
    assert keys.robot_of("facesynth/lab/points") is None
    assert keys.robot_of("facesynth/lab/stats/translator/x") is None
    assert keys.robot_of("other/lab/servo_state/r1") is None
    assert keys.robot_of("facesynth/lab/servo_state/") is None  # no robot named
    assert keys.robot_of("facesynth/lab/servo_state/a b") is None  # not a robot's name
