"""F's pure core alone on the bundled video: thread CPU per frame, against a baseline (issue 28).

    python tools/features_cpu.py [--model full] [--rounds 9] [--passes 3] [--baseline DIR]

Tracks the bundled video once with P's own tracker (``--model``) and keeps its 472 Points
messages in ``--points`` (tracked again only when that file is missing), then runs
``FeatureProcessor.process`` over them in a child process per round: ``--passes`` passes, each
with a fresh processor (so the neutral's first second and the brows' rest search are in it, as
in a run), timed with the thread's CPU clock. With ``--baseline DIR`` (another facesynth
tree, e.g. ``git archive <commit> | tar -x -C DIR``) each round runs that tree's F first, then
this one's, interleaved, and the two must give the same Features bit for bit (their
msgpack's SHA-256 is compared). Prints each round and the medians, with the load average.
Run it under ``nice`` on a shared machine.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

TREE = Path(__file__).resolve().parents[1]


def track(model: str, path: Path) -> None:
    """The bundled video's Points messages, tracked with ``model``, written to ``path``."""
    import cv2
    import msgspec

    from facesynth.app.data import sample_video
    from facesynth.runtime.atomic import write_atomic
    from facesynth.runtime.frames import encode_frame
    from facesynth.services.points.backends.tracker import TrackerBackend, TrackerConfig

    capture = cv2.VideoCapture(str(sample_video()))
    fps = capture.get(cv2.CAP_PROP_FPS)
    backend = TrackerBackend(TrackerConfig(model=model))
    points = []
    while True:
        ok, image = capture.read()
        if not ok:
            break
        seq = len(points)
        t_media = round(seq * 1e9 / fps)
        frame = encode_frame(image, seq=seq, t_capture_ns=seq, t_media_ns=t_media, encoding="raw")
        points.append(backend.process(frame))
    capture.release()
    write_atomic(path, msgspec.msgpack.encode(points), mode=0o644)


def child(points_path: Path, passes: int) -> None:
    """One round in this process's facesynth: per-pass ms a frame, then the outputs' hash."""
    import msgspec

    from facesynth.schemas.messages import Points
    from facesynth.services.features.core import FeatureProcessor

    points = msgspec.msgpack.decode(points_path.read_bytes(), type=list[Points])
    figures, digest = [], ""
    for _ in range(passes):
        processor = FeatureProcessor()
        start = time.thread_time_ns()
        outputs = [processor.process(message) for message in points]
        figures.append((time.thread_time_ns() - start) / len(points) / 1e6)
        digest = hashlib.sha256(msgspec.msgpack.encode(outputs)).hexdigest()
    print(" ".join(f"{figure:.4f}" for figure in figures), digest)


def run_round(tree: Path, points: Path, passes: int) -> tuple[list[float], str]:
    """One child process on ``tree``'s facesynth: its per-pass figures and outputs' hash."""
    environment = {**os.environ, "PYTHONPATH": str(tree)}
    command = [sys.executable, str(Path(__file__).resolve()), "--child", "--points", str(points)]
    result = subprocess.run(
        [*command, "--passes", str(passes)],
        cwd=tree,
        env=environment,
        check=True,
        capture_output=True,
        text=True,
    )
    *figures, digest = result.stdout.split()
    return [float(figure) for figure in figures], digest


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="full", help="tracker model (default full)")
    parser.add_argument("--points", type=Path, help="Points cache (default /tmp/…-MODEL)")
    parser.add_argument("--rounds", type=int, default=9)
    parser.add_argument("--passes", type=int, default=3)
    parser.add_argument("--baseline", type=Path, help="a facesynth tree to compare with")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    points = args.points or Path(f"/tmp/facesynth-features-cpu-points-{args.model}.msgpack")
    if args.child:
        child(points, args.passes)
        return
    if not points.exists():
        track(args.model, points)
    trees = {"baseline": args.baseline.resolve()} if args.baseline else {}
    trees["this tree"] = TREE
    figures: dict[str, list[float]] = {name: [] for name in trees}
    digests: set[str] = set()
    print(f"load average at start: {os.getloadavg()[0]:.1f}")
    for number in range(1, args.rounds + 1):
        line = []
        for name, tree in trees.items():
            passes, digest = run_round(tree, points, args.passes)
            figures[name] += passes
            digests.add(digest)
            line.append(f"{name} " + " ".join(f"{value:.3f}" for value in passes))
        print(f"round {number}: " + "; ".join(line), flush=True)
    print(f"load average at end: {os.getloadavg()[0]:.1f}")
    for name, values in figures.items():
        print(
            f"{name}: median {statistics.median(values):.3f} ms a frame, "
            f"min {min(values):.3f} ({len(values)} passes)"
        )
    if len(trees) > 1:
        print("outputs: " + ("bit for bit the same" if len(digests) == 1 else "DIFFERENT"))
        if len(digests) != 1:
            sys.exit(1)


if __name__ == "__main__":
    main()
