"""Every sub-command's parser builds without the optional extras, as on a servo board that
installed facesynth alone (``make test-board`` checks a real install; this checks each command
that a change adds, in ``make test``): their modules are imported only when they run."""

from __future__ import annotations

import subprocess
import sys

#: The top-level modules of every optional extra (and what they bring).
EXTRAS = (
    "aiohttp",
    "ai_edge_litert",
    "cryptography",
    "cv2",
    "foxglove",
    "mcap",
    "mcap_protobuf",
    "pythonosc",
    "rclpy",
    "rosbags",
    "scipy",
    "sensor_msgs",
    "std_msgs",
    "trajectory_msgs",
    "sklearn",
    "uvloop",
)

PROBE = """
import contextlib, io, sys
BLOCKED = set(sys.argv[1].split(","))
class Block:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in BLOCKED:
            raise ImportError(f"{name} is not installed (blocked)")
        return None
sys.meta_path.insert(0, Block())
from facesynth.app.cli import build_parser
parser = build_parser()
commands = sorted(parser._subparsers._group_actions[0].choices)
for command in commands:
    with contextlib.redirect_stdout(io.StringIO()):
        try:
            parser.parse_args([command, "--help"])
        except SystemExit as exc:
            assert exc.code == 0, command
print(" ".join(commands))
"""


def test_every_command_parses_without_the_extras() -> None:
    done = subprocess.run(
        [sys.executable, "-c", PROBE, ",".join(EXTRAS)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert {"learn", "simhead", "control", "run"} <= set(done.stdout.split())
