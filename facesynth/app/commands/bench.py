"""``facesynth bench``: the benchmarks (:mod:`facesynth.app.bench.command`)."""

from __future__ import annotations

from facesynth.app.bench.arguments import add_bench_arguments
from facesynth.app.bench.command import cmd_bench
from facesynth.app.command_registry import Command

HELP = (
    "benchmarks: the five-process chain, the tracker, smoothing, recording, the live face "
    "page, expression fidelity, servo drivers on the wire, run beside a plain MediaPipe script"
)

COMMANDS = (Command("bench", HELP, cmd_bench, add_bench_arguments),)
