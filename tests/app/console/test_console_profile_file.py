"""Saving a profile from the console: TOML that reads back identically, written atomically,
with the previous file kept; an invalid profile writes nothing."""

from __future__ import annotations

import datetime
import os
from pathlib import Path

import msgspec
import pytest

from facesynth.app.console.profile_file import backup_path, profile_toml, save_path, save_profile
from facesynth.app.console.rig import ConsoleRig
from facesynth.runtime.profiles import (
    PACKAGE_DIR,
    ProfileError,
    available_profiles,
    load_profile,
    parse_profile,
    resolve_profile,
)

NOW = datetime.datetime(2026, 11, 24, 9, 0, tzinfo=datetime.UTC)


@pytest.mark.parametrize("name", [n for n in available_profiles(hardware=True)])
def test_every_shipped_profile_reads_back_identically(name: str) -> None:
    profile = load_profile(name)
    if profile.learned is not None:
        with pytest.raises(ProfileError, match="is learned"):
            profile_toml(profile)
        return
    assert parse_profile(profile_toml(profile)) == profile


def test_an_edited_profile_is_saved_with_a_backup_and_reloads_identically(tmp_path: Path) -> None:
    path = tmp_path / "head.toml"
    original = (Path(PACKAGE_DIR) / "head16_hardware.toml").read_text()
    path.write_text(original)
    rig = ConsoleRig(load_profile(str(path)))
    rig.report(rig.active.name, {rig.active.servos[3].name: 1321.5})
    rig.set_limit(3, "min")
    rig.set_limit(3, "max", 2150.0)
    rig.rename(3, "eye_right_x")
    rig.reverse(3, True)
    backup = save_profile(rig.draft, path, now=NOW)
    assert backup == backup_path(path) == tmp_path / "head.toml.bak"
    assert backup.read_text() == original
    reloaded = load_profile(str(path))
    assert reloaded == rig.draft
    spec = reloaded.servos[3]
    assert (spec.name, spec.min_us, spec.max_us, spec.reversed) == (
        "eye_right_x", 1321.5, 2150.0, True,
    )  # fmt: skip
    text = path.read_text()
    assert text.startswith("# head16_hardware: written by facesynth console at 2026-11-24T09:00")
    assert oct(os.stat(path).st_mode & 0o777) == "0o644"
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


def test_the_first_save_has_no_backup(tmp_path: Path) -> None:
    path = tmp_path / "new.toml"
    assert save_profile(load_profile("head16"), path) is None
    assert load_profile(str(path)) == load_profile("head16")
    assert not backup_path(path).exists()


def test_an_invalid_profile_writes_nothing(tmp_path: Path) -> None:
    path = tmp_path / "head.toml"
    path.write_text("keep me")
    profile = load_profile("head16_hardware")
    broken = msgspec.structs.replace(profile.servos[0], min_us=1600.0)  # above its neutral
    bad = msgspec.structs.replace(profile, servos=[broken, *profile.servos[1:]])
    with pytest.raises(ProfileError, match="min_us"):
        save_profile(bad, path)
    assert path.read_text() == "keep me"
    assert not backup_path(path).exists()


def test_a_shipped_profile_is_saved_to_the_users_folder(isolated_home: Path) -> None:
    shipped = resolve_profile("head16_hardware")
    assert save_path(shipped, "head16_hardware") == (
        isolated_home / ".config" / "facesynth" / "profiles" / "head16_hardware.toml"
    )
    own = isolated_home / "mine.toml"
    assert save_path(own, "head16_hardware") == own
