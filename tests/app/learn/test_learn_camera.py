"""learn's robot camera only measures the face: its frames name no capture host, so no stage
drops them for their age (a loaded host's slow tracker must not cost the babbling its poses)."""

from __future__ import annotations

from pathlib import Path

from facesynth.app.cli import build_parser
from facesynth.app.learn.babble_flags import rig_configs
from facesynth.app.robot_rig import build_parts
from facesynth.runtime.profiles import load_profile

DATA = Path(__file__).resolve().parents[3] / "facesynth" / "app" / "data"
VIDEO = DATA / "WolfgangLanger_Pexels.mp4"


def test_the_robot_cameras_frames_are_never_aged_from_capture(tmp_path: Path) -> None:
    out = tmp_path / "s.mcap"
    argv = ["learn", "--profile", "paper16", "--video", str(VIDEO), "--out", str(out)]
    args = build_parser().parse_args(argv)
    parts = build_parts(
        args.profile,
        "default",
        load_profile("paper16"),
        rig_configs(args, out.with_suffix(".commands.jsonl")),
    )
    assert parts["sensor"].service.options.capture_age is False
    assert parts["sensor"].service.capture_host == ""
