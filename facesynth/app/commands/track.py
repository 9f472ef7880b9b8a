"""``facesynth track VIDEO --out FILE``: a video tracked offline, one JSON line a frame."""

from __future__ import annotations

import argparse
import json
import logging

from facesynth.app.command_registry import Command
from facesynth.app.common_arguments import model_arguments
from facesynth.runtime.outputs import check_output
from facesynth.services.points.tracker.runtimes import backend_choices

log = logging.getLogger("facesynth")


def cmd_track(args: argparse.Namespace) -> int:
    """``facesynth track VIDEO --out FILE``."""
    from facesynth.services.points.tracker.landmarkers import model_config
    from facesynth.services.points.tracker.offline import track_video

    check_output(args.out, "track file")
    options = {"blendshapes": args.blendshapes} if args.model == "full" else {}
    model = model_config(args.model, **options)
    summary = track_video(args.video, args.out, backend=args.inference, model=model)
    print(json.dumps(summary))
    return 0


HELP = "track a video offline: one JSON line of landmarks per frame"


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("video")
    p.add_argument("--out", required=True, help="output JSON-lines file")
    p.add_argument(
        "--inference",
        choices=backend_choices(),
        default="auto",
        help="inference runtime (default auto: LiteRT when installed)",
    )
    model_arguments(p)


COMMANDS = (Command("track", HELP, cmd_track, _arguments),)
