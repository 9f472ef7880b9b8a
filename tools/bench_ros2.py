"""facesynth in a ROS 2 graph: latency and rate against a real rclpy process (issue 25).

    sudo .venv/bin/python tools/bench_ros2.py [--frames 450] [--domain 57] [--shared-robot]

Needs the ``[ros2]`` extra and root: it runs itself again in a network namespace with only
loopback (``unshare -n``), with ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` and a
``ROS_DOMAIN_ID`` of its own, so DDS discovery never leaves the machine; rclpy processes start
with ``spawn``.

1. **Driver**: the bundled performer video (23.976 fps) played at 30 fps in real time
   (``--frames`` frames, tracker in P) drives a robot of two control nodes on the same
   commands (paper16, commands executed up to 5 s old so both execute the same ones), the
   ``record`` driver and the ``ros2`` driver (JointState, reliable, depth 10), each a
   ``facesynth control`` process of its own as a robot runs one (``--shared-robot``:
   both in one process, where the ros2 node takes each command after the record node); a
   subscriber in another process notes when each JointState arrives. Capture -> record driver
   (its ``t_sent_ns``, when C decided the move) against capture -> JointState taken by the
   subscriber's Python (the header stamp is the capture time): p50/p90/p99, the rate held and
   how many commands never arrived; and where the difference goes (the middleware's source
   and reception timestamps split it).
2. **Source**: a publisher in another process sends the performer video's frames as JPEG
   CompressedImage at 30 fps (best effort, stamped when sent); the chain reads them with the
   ``ros2`` source: the rate of frames taken and of frames with a face, capture -> command p50,
   and how many images the chain skipped (it keeps the latest only).
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import re
import shutil
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from facesynth.runtime.profiles import PACKAGE_DIR

ROOT = Path(__file__).resolve().parents[1]
RIG = "benchros2"
TOPIC = "/facesynth/joint_commands"
CAMERA = "/camera/image_raw/compressed"
#: A service's last line: how many commands a control node received and applied (published).
STOPPED = re.compile(r"stopped: received (\d+), published (\d+)")


def loopback_only() -> bool:
    return [name for _, name in socket.if_nameindex()] == ["lo"]


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _subscriber(out: str, ready: Any, stop: Any) -> None:
    """Take each JointState as it arrives and note, per message: its stamp (the capture), when
    Python had it (``take_message`` returned), and the middleware's source (the publisher's
    write) and reception timestamps.

    It waits on a wait set of its one subscription, as ``rclpy.wait_for_message`` does, and
    takes the messages itself: rclpy's executor (``spin_once``) spends 0.2-0.3 ms more of
    Python per message on this machine, a cost of the subscriber's choice of executor, not of
    the path from facesynth to it."""
    import rclpy
    from rclpy.impl.implementation_singleton import rclpy_implementation
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState

    rclpy.init()
    node = rclpy.create_node("bench_subscriber")
    seen: list[tuple[int, int, int, int]] = []
    qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
    subscription = node.create_subscription(JointState, TOPIC, lambda _: None, qos)
    wait_set = rclpy_implementation.WaitSet(1, 0, 0, 0, 0, 0, node.context.handle)
    ready.set()
    with subscription.handle:
        while not stop.is_set():
            wait_set.clear_entities()
            wait_set.add_subscription(subscription.handle)
            wait_set.wait(50_000_000)  # ns: the stop event is looked at as often
            while (taken := subscription.handle.take_message(JointState, False)) is not None:
                now = time.time_ns()
                msg, info = taken
                stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
                seen.append((stamp, now, info["source_timestamp"], info["received_timestamp"]))
    Path(out).write_text(json.dumps(seen))
    node.destroy_node()
    rclpy.shutdown()


def _camera(count_file: str, ready: Any, stop: Any) -> None:
    import cv2
    import rclpy
    from rclpy.qos import qos_profile_sensor_data
    from sensor_msgs.msg import CompressedImage

    from facesynth.app.data import sample_video

    capture = cv2.VideoCapture(str(sample_video()))
    jpegs = []
    while len(jpegs) < 300:
        ok, frame = capture.read()
        if not ok:
            break
        jpegs.append(bytes(cv2.imencode(".jpg", frame)[1]))
    rclpy.init()
    node = rclpy.create_node("bench_camera")
    publisher = node.create_publisher(CompressedImage, CAMERA, qos_profile_sensor_data)
    ready.set()
    start, index = time.monotonic(), 0
    while not stop.is_set():
        time.sleep(max(0.0, start + index / 30.0 - time.monotonic()))
        msg = CompressedImage(format="jpeg", data=jpegs[index % len(jpegs)])
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(time.time_ns(), 1_000_000_000)
        publisher.publish(msg)
        index += 1
    Path(count_file).write_text(str(index))
    node.destroy_node()
    rclpy.shutdown()


class Peer:
    def __init__(self, target: Any, out: Path) -> None:
        spawn = multiprocessing.get_context("spawn")
        self.ready, self.stop_event = spawn.Event(), spawn.Event()
        self.process = spawn.Process(target=target, args=(str(out), self.ready, self.stop_event))
        self.process.start()
        if not self.ready.wait(60):
            raise SystemExit("the rclpy process did not start")

    def stop(self) -> None:
        self.stop_event.set()
        self.process.join(20)


def facesynth(*args: str, log: Path) -> subprocess.Popen[bytes]:
    with open(log, "wb") as handle:
        return subprocess.Popen(
            [sys.executable, "-m", "facesynth", *args], stdout=handle, stderr=subprocess.STDOUT
        )


def wait_for(log: Path, text: str, count: int, timeout: float = 90) -> None:
    deadline = time.monotonic() + timeout
    while log.read_text(errors="replace").count(text) < count:
        if time.monotonic() > deadline:
            raise SystemExit(f"{log.name} never said {text!r} {count} times")
        time.sleep(0.1)


def percentiles(values: list[float]) -> str:
    ordered = sorted(values)
    at = [ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))] for q in (0.5, 0.9, 0.99)]
    return " / ".join(f"{v:6.2f}" for v in at)


def records(path: Path) -> list[dict[str, Any]]:
    lines = [json.loads(line) for line in path.read_text().splitlines()]
    return [line for line in lines if "seq" in line and line["frame"] is not None]


def bench_driver(folder: Path, frames: int, shared: bool = False) -> dict[str, Any]:
    """The record and ros2 control nodes each in a process of its own (``shared``: both in one
    ``facesynth run``, where the second takes each command after the first is done with it)."""
    port = free_port()
    router = facesynth("router", "--listen", f"tcp/127.0.0.1:{port}", log=folder / "router.log")
    connect = ["--mode", "client", "--connect", f"tcp/127.0.0.1:{port}"]
    robot_graph, performer_graph = folder / "robot.toml", folder / "performer.toml"
    # paper16, its commands executed up to 5 s old: each control node judges a command's age
    # on its own, and on a loaded machine one could drop a command the other executed; so a
    # command the record driver wrote and no JointState carries is one the middleware lost.
    robot = folder / "paper16.toml"
    paper16 = (Path(PACKAGE_DIR) / "paper16.toml").read_text()
    robot.write_text(
        paper16.replace("\nneutral_ramp_s", "\nmax_command_age_s = 5\nneutral_ramp_s", 1)
    )
    robot_graph.write_text(
        f'rig = "{RIG}"\n[nodes.record]\nstage = "control"\nprofile = "{robot}"\n'
        f'driver = {{ driver = "record", out = "{folder}/commands.jsonl" }}\n'
        f'[nodes.ros2]\nstage = "control"\nprofile = "{robot}"\ndriver = {{ driver = "ros2" }}\n'
    )
    performer_graph.write_text(
        f'rig = "{RIG}"\n[nodes.sensor]\nstage = "sensor"\n'
        'source = { source = "video", fps = 30.0 }\n'
        '[nodes.points]\nstage = "points"\nbackend = { backend = "tracker" }\n'
        '[nodes.features]\nstage = "features"\n'
        '[nodes.translator]\nstage = "translator"\nprofile = "paper16"\n'
    )
    subscriber = Peer(_subscriber, folder / "received.json")
    robots: list[subprocess.Popen[bytes]] = []
    try:
        if shared:
            log = folder / "robot.log"
            robots.append(facesynth("run", str(robot_graph), *connect, log=log))
            wait_for(log, "control interface on", 2)
        else:
            for node in ("record", "ros2"):
                log = folder / f"robot-{node}.log"
                graph = ["--graph", str(robot_graph), "--node", node]
                robots.append(facesynth("control", *graph, *connect, log=log))
            for node in ("record", "ros2"):
                wait_for(folder / f"robot-{node}.log", "control interface on", 1)
        performer = facesynth(
            "run", str(performer_graph), *connect, "--max-frames", str(frames),
            log=folder / "performer.log",
        )  # fmt: skip
        if performer.wait(frames / 30 + 120) != 0:
            raise SystemExit((folder / "performer.log").read_text()[-2000:])
    finally:
        for robot in robots:
            robot.send_signal(signal.SIGTERM)
        for robot in robots:
            robot.wait(30)
        subscriber.stop()
        router.send_signal(signal.SIGTERM)
        router.wait(15)
    sent = records(folder / "commands.jsonl")
    received = {row[0]: row[1:] for row in json.loads((folder / "received.json").read_text())}
    both = [
        (line, received[line["t_capture_ns"]]) for line in sent if line["t_capture_ns"] in received
    ]
    record_ms = [(line["t_sent_ns"] - line["t_capture_ns"]) / 1e6 for line in sent]
    ros_ms = [(taken - line["t_capture_ns"]) / 1e6 for line, (taken, _, _) in both]
    span_s = (sent[-1]["t_capture_ns"] - sent[0]["t_capture_ns"]) / 1e9
    return {
        "commands": len(sent),
        "received": len(ros_ms),
        "lost": len(sent) - len(ros_ms),
        "fps": (len(sent) - 1) / span_s,
        "record_ms": percentiles(record_ms),
        "ros2_ms": percentiles(ros_ms),
        "p50_above_record_ms": statistics.median(ros_ms) - statistics.median(record_ms),
        "paired_p50_above_record_ms": statistics.median(
            [(taken - line["t_sent_ns"]) / 1e6 for line, (taken, _, _) in both]
        ),
        "lost_frames": [line["frame"] for line in sent if line["t_capture_ns"] not in received],
        # Each control node's commands received and applied (a command older than the
        # profile's max_command_age_s is dropped, by each node on its own clock readings).
        "control_nodes": [
            f"{taken}/{applied}"
            for log in sorted(folder.glob("robot*.log"))
            for taken, applied in STOPPED.findall(log.read_text(errors="replace"))
        ],
        # Where a JointState spends the time after the record driver's: the ros2 control node
        # takes the command, decides, builds and writes the message (the middleware's source
        # timestamp); the middleware carries it to the other process (its reception
        # timestamp); that process's Python takes it.
        "record_to_write_ms": percentiles(
            [(source - line["t_sent_ns"]) / 1e6 for line, (_, source, _) in both]
        ),
        "write_to_reception_ms": percentiles(
            [(reception - source) / 1e6 for _, (_, source, reception) in both]
        ),
        "reception_to_taken_ms": percentiles(
            [(taken - reception) / 1e6 for _, (taken, _, reception) in both]
        ),
    }


def bench_source(folder: Path, frames: int) -> dict[str, Any]:
    camera = Peer(_camera, folder / "published.txt")
    started = time.time_ns()
    try:
        done = facesynth(
            "run", "--source", "ros2", "--ros2-image-topic", CAMERA, "--max-frames", str(frames),
            "--out", str(folder / "camera.jsonl"), "--listen", "tcp/127.0.0.1:0",
            log=folder / "camera.log",
        )  # fmt: skip
        if done.wait(frames / 30 + 120) != 0:
            raise SystemExit((folder / "camera.log").read_text()[-2000:])
    finally:
        camera.stop()
    taken = records(folder / "camera.jsonl")
    span_s = (taken[-1]["t_capture_ns"] - taken[0]["t_capture_ns"]) / 1e9
    skipped = round(span_s * 30) + 1 - len(taken)
    return {
        "frames": len(taken),
        "with_face": sum(line["face"] for line in taken),
        "fps": (len(taken) - 1) / span_s,
        "capture_to_command_ms": percentiles(
            [(line["t_sent_ns"] - line["t_capture_ns"]) / 1e6 for line in taken]
        ),
        "images_skipped": max(0, skipped),
        "seconds": (time.time_ns() - started) / 1e9,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=450)
    parser.add_argument("--domain", type=int, default=57, help="ROS_DOMAIN_ID (default 57)")
    parser.add_argument(
        "--shared-robot",
        action="store_true",
        help="run the record and ros2 control nodes in one process (the second takes each "
        "command after the first); default: a process each",
    )
    parser.add_argument(
        "--keep", metavar="DIR", help="write the logs and files there (default: a temporary one)"
    )
    parser.add_argument("--inside", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if not loopback_only():
        if args.inside or os.geteuid() != 0 or shutil.which("unshare") is None:
            raise SystemExit("run it as root: it runs in a network namespace with only loopback")
        command = " ".join([sys.executable, str(Path(__file__).resolve()), *sys.argv[1:]])
        return subprocess.call(
            ["unshare", "-n", "sh", "-c", f"ip link set lo up && exec {command} --inside"]
        )
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ["ROS_DOMAIN_ID"] = str(args.domain)
    with tempfile.TemporaryDirectory(prefix="facesynth-bench-ros2-") as tmp:
        folder = Path(args.keep or tmp)
        folder.mkdir(parents=True, exist_ok=True)
        if any(folder.iterdir()):
            raise SystemExit(f"--keep {folder}: not empty (a record file there would be added to)")
        driver = bench_driver(folder, args.frames, args.shared_robot)
        source = bench_source(folder, args.frames)
    print(f"ros2 driver, {driver['commands']} commands of the performer video at 30 fps:")
    print(f"  capture -> record driver      p50/p90/p99 ms {driver['record_ms']}")
    print(f"  capture -> JointState (rclpy) p50/p90/p99 ms {driver['ros2_ms']}")
    print("  after the record driver, p50/p90/p99 ms:")
    print(f"    record driver -> JointState written   {driver['record_to_write_ms']}")
    print(f"    written -> received by the middleware {driver['write_to_reception_ms']}")
    print(f"    received -> taken in Python           {driver['reception_to_taken_ms']}")
    print(
        f"  p50 above the record driver {driver['p50_above_record_ms']:.2f} ms (p50 of each "
        f"command's difference {driver['paired_p50_above_record_ms']:.2f} ms); "
        f"{driver['fps']:.2f} fps held; {driver['lost']} lost"
    )
    nodes = ", ".join(driver["control_nodes"])
    print(f"  control nodes' commands received/applied: {nodes}")
    print(f"ros2 source, {source['frames']} JPEG CompressedImage frames at 30 fps:")
    print(
        f"  {source['fps']:.2f} fps taken, {source['with_face']} with a face, "
        f"{source['images_skipped']} images skipped"
    )
    print(f"  capture (stamp) -> command p50/p90/p99 ms {source['capture_to_command_ms']}")
    print(f"  load average {os.getloadavg()[0]:.2f}")
    print(json.dumps({"driver": driver, "source": source}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
