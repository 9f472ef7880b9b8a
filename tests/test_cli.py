"""The ``facesynth`` command: help everywhere, and one clear error line (exit 2) for bad input."""

from __future__ import annotations

import asyncio
import os
import re
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
from aiohttp import web

from facesynth.app.cli import build_parser, main
from facesynth.app.data import sample_openface_csv, sample_video
from facesynth.app.learn.session import metadata
from facesynth.app.recording.writer import SessionWriter
from facesynth.runtime.profiles import load_profile

COMMANDS = [
    "run",
    "sensor",
    "points",
    "features",
    "translator",
    "control",
    "router",
    "status",
    "profile",
    "bench",
    "track",
    "plan",
    "compose",
    "calibrate",
    "firmware",
    "render",
    "certs",
    "health",
    "learn",
    "simhead",
    "doctor",
    "console",
]


@pytest.mark.parametrize("command", COMMANDS)
def test_help(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main([command, "--help"])
    assert exit_info.value.code == 0
    assert "usage: facesynth " + command in capsys.readouterr().out


def _files(tmp: Path) -> dict[str, Path]:
    files = {
        "bad.toml": "name = \n",
        "unknown.toml": 'name = "x"\nwheels = 4\n[[servos]]\nname = "a"\n',
        "bad.json": "{not json",
        "short.json": '{"name": "p", "neutral": [1.0], "delta_min": [0.0], "delta_max": [0.0]}',
        "driver.toml": 'driver = "teleporter"\n',
        "garbage.csv": "a, b\n1, 2\n",
        "garbage.mp4": "this is not a video",
        "bad.json5": "{ mode: ",
        "track.jsonl": '{"frame": 0, "face": true, "ibug68": [[1, 2]]}\n',
        "blend.jsonl": '{"frame": 0, "face": true, "ibug68": '
        + str([[1.0, 2.0]] * 68)
        + ', "blendshapes": [0.5, 2.0]}\n',
        "graph.toml": '[nodes.control]\nstage = "control"\n[nodes.f]\nstage = "features"\n',
        "nodriver.toml": '[nodes.c]\nstage = "control"\ndriver = { driver = "record" }\n',
        "badgraph.toml": "[nodes.x\n",
        "vmcgraph.toml": '[nodes.c]\nstage = "control"\nprofile = "paper16"\n'
        'driver = { driver = "vmc" }\n',
        "features.toml": '[nodes.f]\nstage = "features"\n',
        "robotgraph.toml": '[nodes.t]\nstage = "translator"\nrobot = "a b"\n',
        "agegraph.toml": '[nodes.p]\nstage = "points"\nmax_input_age_s = -0.5\n',
        "servotable.toml": 'name = "t"\n\n[servos.jaw]\nchannel = 0\n',
        "noavatar.toml": (
            'name = "noavatar"\n[[servos]]\nname = "tail"\nchannel = 0\nfeature = "jaw_open"\n'
            "min_us = 1000\nneutral_us = 1500\nmax_us = 2000\n"
        ),
    }
    for name, text in files.items():
        (tmp / name).write_text(text)
    paths = {name: tmp / name for name in files}
    # The bundled video cut at 5 % of its bytes: its container announces 472 frames, 17 decode.
    truncated = tmp / "truncated.mp4"
    video = sample_video().read_bytes()
    truncated.write_bytes(video[: len(video) // 20])
    # a learned profile from a later facesynth (msgpack: {format: ..., version: 3})
    future = tmp / "future.learned"
    future.write_bytes(b"\x82\xa6format\xb9facesynth.learned_profile\xa7version\x04")
    folder = tmp / "a-folder"
    folder.mkdir()
    # a babbling session of paper16 whose fixed plan swept in 3 steps a neutral every 25
    session = tmp / "session.mcap"
    plan = {"learn_sweep_steps": "3", "learn_neutral_every": "25"}
    meta = metadata("self", load_profile("paper16"), 0, ["babble"], "fixed", plan)
    SessionWriter(session, metadata=meta).close()
    return {
        **paths,
        "truncated.mp4": truncated,
        "a-folder": folder,
        "future.learned": future,
        "session.mcap": session,
    }


CASES = [
    ("missing profile", ["translator", "--profile", "/nonexistent/robot.toml"], "does not exist"),
    ("unknown profile", ["translator", "--profile", "no_such_robot"], "available: "),
    ("broken profile", ["translator", "--profile", "{bad.toml}"], "not valid TOML"),
    ("unknown profile field", ["control", "--profile", "{unknown.toml}", "--out", "x"], "wheels"),
    ("broken calibration", ["features", "--calibration", "{bad.json}"], "JSON"),
    ("short calibration", ["translator", "--calibration", "{short.json}"], "needs 68"),
    ("unknown driver", ["control", "--driver-config", "{driver.toml}"], "teleporter"),
    ("record without out", ["control"], "needs --out"),
    ("not OpenFace", ["points", "--openface-csv", "{garbage.csv}"], "missing columns"),
    ("bad track file", ["points", "--points-jsonl", "{track.jsonl}"], "68 finite"),
    ("bad track blendshapes", ["points", "--points-jsonl", "{blend.jsonl}"], "52 numbers in 0..1"),
    ("unknown tracker model", ["points", "--model", "huge"], "unknown tracker model 'huge'"),
    ("unknown bench model", ["bench", "tracker", "--models", "fast,huge"], "unknown huge;"),
    (
        "mediapipe without task",
        ["bench", "tracker", "--mediapipe-python", "python3", "--frames", "2"],
        "needs --mediapipe-task",
    ),
    (
        "mediapipe task missing",
        ["bench", "tracker", "--mediapipe-python", "python3", "--mediapipe-task", "/no.task"],
        "task file not found",
    ),
    ("bench repeat", ["bench", "tracker", "--repeat", "0", "--frames", "2"], "--repeat"),
    ("fidelity model", ["bench", "fidelity", "--models", "slow"], "--models: unknown slow;"),
    (
        "blendshape profile, fast model",
        ["run", "--model", "fast", "--profile", "head16_bs", "--listen", "tcp/127.0.0.1:0"],
        "profile head16_bs is driven by blendshapes (browDownLeft",
    ),
    (
        "blendshape profile, no blendshapes",
        ["run", "--no-blendshapes", "--profile", "arkit52", "--listen", "tcp/127.0.0.1:0"],
        "use the tracker with --model full (and blendshapes)",
    ),
    (
        "blendshape profile, openface replay",
        ["run", "--openface-csv", str(sample_openface_csv()), "--profile", "arkit52"],
        "profile arkit52 is driven by blendshapes",
    ),
    ("fidelity profile", ["bench", "fidelity", "--profiles", "head16,robo9"], "'robo9'"),
    ("not a video", ["sensor", "--video", "{garbage.mp4}"], "cannot open"),
    ("missing video", ["sensor", "--video", "/nonexistent.mp4"], "does not exist"),
    ("two sources", ["sensor", "--video", "{garbage.mp4}", "--ticks", "3"], "choose one"),
    ("bad window", ["sensor", "--ticks", "3", "--window", "0"], "--window"),
    ("bad threads", ["points", "--threads", "0"], "--threads"),
    ("bad redetect", ["points", "--redetect-every", "0"], "--redetect-every"),
    (
        "broken zenoh config",
        ["router", "--zenoh-config", "{bad.json5}"],
        "cannot load Zenoh config",
    ),
    (
        "unreachable router, no waiting",
        ["features", "--mode", "client", "--connect", "tcp/127.0.0.1:9", "--router-timeout", "0"],
        "cannot open a Zenoh client session",
    ),
    (
        "truncated video",
        [
            "run",
            "--video",
            "{truncated.mp4}",
            "--openface-csv",
            str(sample_openface_csv()),
            "--fast",
            "--listen",
            "tcp/127.0.0.1:0",
            "--out",
            "{a-folder}/c.jsonl",
        ],
        "video truncated or corrupt: decoded 17 of 472 frames from",
    ),
    (
        "truncated video, calibrating",
        [
            "calibrate",
            "alice",
            "--video",
            "{truncated.mp4}",
            "--out",
            "{a-folder}/a.json",
            "--schedule",
            "neutral=0-2",
        ],
        "video truncated or corrupt: decoded 17 of 472 frames",
    ),
    (
        "record file is a directory",
        ["control", "--out", "{a-folder}"],
        "is a directory, not a file",
    ),
    (
        "record file in an unwritable place",
        ["control", "--out", "/proc/facesynth/commands.jsonl"],
        "cannot write record file /proc/facesynth/commands.jsonl: /proc is not writable",
    ),
    (
        "record file under a file",
        ["run", "--out", "{bad.toml}/c.jsonl", "--listen", "tcp/127.0.0.1:0"],
        "bad.toml is not a directory",
    ),
    (
        "run renders to an unwritable place",
        ["run", "--render", "/proc/side.mp4", "--listen", "tcp/127.0.0.1:0", "--out", "x"],
        "cannot write video /proc/side.mp4: /proc is not writable",
    ),
    (
        "run renders to a text file",
        ["run", "--render", "side.txt", "--listen", "tcp/127.0.0.1:0", "--out", "x"],
        "use a .mp4, .mov, .mkv, .avi file",
    ),
    (
        "run records over a file",
        ["run", "--record", "{bad.toml}", "--listen", "tcp/127.0.0.1:0", "--out", "x"],
        "exists (a session file is never overwritten)",
    ),
    ("render into a folder", ["render", "--out", "{a-folder}"], "use a .mp4"),
    ("render to /proc", ["render", "--out", "/proc/o.mp4"], "/proc is not writable"),
    (
        "track to an unwritable place",
        ["track", "{garbage.mp4}", "--out", "/proc/track.jsonl"],
        "cannot write track file /proc/track.jsonl",
    ),
    (
        "calibration to an unwritable place",
        ["calibrate", "alice", "--ticks", "3", "--out", "/proc/alice.json"],
        "cannot write calibration /proc/alice.json",
    ),
    ("performer not a file name", ["features", "--performer", "../x"], "cannot name a state file"),
    (
        "media motion time for hardware",
        ["control", "--driver", "ssc32", "--port", "/dev/null", "--motion-time", "media"],
        "not for the ssc32 driver: it moves a real head",
    ),
    (
        "unknown motion time",
        ["control", "--out", "x", "--motion-time", "sideways"],
        "--motion-time",
    ),
    ("profile check broken", ["profile", "check", "{bad.toml}"], "not valid TOML"),
    (
        "profile servos as a table",
        ["profile", "check", "{servotable.toml}"],
        "line 3: servos are written as [[servos]] tables",
    ),
    ("missing graph", ["run", "/nonexistent/g.toml"], "graph /nonexistent/g.toml does not exist"),
    ("broken graph", ["features", "--graph", "{badgraph.toml}"], "not valid TOML"),
    ("node without graph", ["features", "--node", "f"], "--node needs --graph"),
    (
        "node of another stage",
        ["features", "--graph", "{graph.toml}", "--node", "control"],
        "node 'control' runs control, not features",
    ),
    (
        "option of another backend",
        ["points", "--threads", "2", "--openface-csv", "{garbage.csv}"],
        "--threads does not apply to backend openface",
    ),
    (
        "two backends",
        ["points", "--openface-csv", "a", "--points-jsonl", "b"],
        "choose one backend",
    ),
    (
        "compose outside deploy",
        ["compose", "{features.toml}", "--graph-path", "/tmp/g.toml"],
        "--graph-path must lie in /etc/facesynth",
    ),
    ("graph without out", ["control", "--graph", "{nodriver.toml}"], "driver record needs --out"),
    (
        "compose checks drivers",
        ["compose", "{nodriver.toml}"],
        "Object missing required field `out`",
    ),
    ("bad watchdog", ["control", "--out", "x", "--watchdog", "0"], "--watchdog: Expected"),
    ("profile without name", ["profile", "check"], "needs a profile"),
    (
        "control test without a servo",
        ["control", "test", "--driver", "ssc32", "--port", "/nonexistent/tty"],
        "test needs --servo NAME or --all",
    ),
    (
        "control test of an unknown servo",
        ["control", "test", "--servo", "nose", "--out", "x"],
        "profile 'paper16' has no servo 'nose'",
    ),
    ("test option without test", ["control", "--servo", "jaw", "--out", "x"], "control test`"),
    ("status option of test", ["control", "status", "--all", "--out", "x"], "an option of test"),
    ("control status of record", ["control", "status", "--out", "x"], "has no device to query"),
    (
        "control status without a board",
        ["control", "status", "--driver", "maestro", "--port", "/nonexistent/tty"],
        "/nonexistent/tty: cannot open it: No such file or directory",
    ),
    (
        "control status without an I2C bus",
        ["control", "status", "--driver", "pca9685", "--i2c-bus", "/dev/i2c-99"],
        "/dev/i2c-99: cannot open it: No such file or directory",
    ),
    (
        "a PCA9685 address that is not one",
        ["control", "--driver", "pca9685", "--i2c-address", "0x99"],
        "--i2c-address: 0x99 is outside the 7-bit device addresses 0x03..0x77",
    ),
    (
        "a PCA9685 frame rate it cannot make",
        ["control", "--driver", "pca9685", "--pca9685-frequency", "2000"],
        "--pca9685-frequency: 2000 Hz needs PRE_SCALE 2, outside 3..255",
    ),
    (
        "a smart bus read-back rate of nothing",
        ["control", "--driver", "dynamixel", "--port", "/dev/null", "--bus-read-hz", "0"],
        "driver dynamixel: --bus-read-hz: Expected `float` > 0.0",
    ),
    (
        "malformed port URL",
        ["control", "--driver", "ssc32", "--port", "socket://nohost"],
        "socket://nohost: expected socket://HOST:PORT",
    ),
    ("driver without port", ["control", "--driver", "arduino"], "driver arduino needs --port"),
    (
        "board too small",
        ["control", "--driver", "maestro", "--port", "/dev/null", "--maestro-model", "micro6"],
        "channel 15, but the Micro Maestro 6 has channels 0..5",
    ),
    (
        "board watchdog out of range",
        ["control", "--driver", "arduino", "--port", "p", "--board-watchdog-ms", "10"],
        "--board-watchdog-ms: Expected `int` >= 20",
    ),
    ("flash without port", ["firmware", "flash"], "flash needs --port"),
    ("flash options on build", ["firmware", "build", "--port", "p"], "options of flash"),
    ("flash all variants", ["firmware", "flash", "--port", "p", "--variant", "all"], "one variant"),
    (
        "missing hex",
        ["firmware", "flash", "--port", "p", "--hex", "/nonexistent.hex"],
        "/nonexistent.hex does not exist",
    ),
    ("no firmware sources", ["firmware", "build", "--firmware-dir", "/nonexistent"], "no firmware"),
    ("render to a text file", ["render", "--out", "x.txt"], "use a .mp4, .mov, .mkv, .avi file"),
    (
        "render a missing video",
        ["render", "--video", "/nonexistent.mp4", "--out", "o.mp4"],
        "does not exist",
    ),
    ("render a camera", ["render", "--camera", "0", "--out", "o.mp4"], "needs a video file"),
    ("render a loop", ["render", "--loop", "--out", "o.mp4"], "never ends"),
    ("render ticks", ["render", "--ticks", "5", "--out", "o.mp4"], "needs a video file"),
    ("render bars of no profile", ["render", "--bars", "nope", "--out", "o.mp4"], "available:"),
    (
        "render with a bad track file",
        ["render", "--points-jsonl", "{track.jsonl}", "--out", "o.mp4"],
        "68 finite",
    ),
    (
        "virtual page address",
        ["control", "--profile", "virtual", "--driver", "virtual", "--http", "8080"],
        "--http: expected HOST:PORT",
    ),
    ("vmc port", ["control", "--driver", "vmc", "--vmc-port", "0"], "--vmc-port"),
    (
        "vmc host",
        ["control", "--driver", "vmc", "--profile", "virtual", "--vmc-host", "no.such.invalid"],
        "--vmc-host: cannot resolve",
    ),
    ("vmc head position", ["control", "--driver", "vmc", "--head-position", "1,2"], "length"),
    (
        "vmc profile without avatar controls",
        ["control", "--driver", "vmc", "--profile", "{noavatar.toml}"],
        "the vmc driver cannot show 1 of the 1 controls of profile noavatar (tail)",
    ),
    (
        "vmc with a servo profile",
        ["run", "--driver", "vmc", "--profile", "paper16"],
        "the vmc driver cannot show 15 of the 16 controls of profile paper16 (right_eyebrow, "
        "left_eyebrow, middle_eyebrow, right_eye_x, …); it shows ARKit blendshape names, the "
        "virtual profile's controls and head_yaw/pitch/roll: choose --profile arkit52 or virtual",
    ),
    (
        "vmc with a head profile, as a service",
        ["control", "--driver", "vmc", "--profile", "head16"],
        "the vmc driver cannot show",
    ),
    (
        "doctor: a graph that cannot run here",
        ["doctor", "--driver", "vmc", "--profile", "paper16", "--listen", "tcp/127.0.0.1:0"],
        "graph demo cannot run on this host: 1 thing to fix (profile paper16 (node control)), "
        "said above",
    ),
    ("doctor: no such graph", ["doctor", "nosuchgraph"], "graph nosuchgraph does not exist"),
    (
        "doctor: a flag of another driver",
        ["doctor", "--driver", "vmc", "--port", "/dev/ttyACM0"],
        "--port does not apply to driver vmc",
    ),
    (
        "vmc with a servo profile in a graph",
        ["run", "{vmcgraph.toml}"],
        "the vmc driver cannot show 15 of the 16 controls of profile paper16",
    ),
    (
        "run frame encoding",
        ["run", "--encoding", "png", "--listen", "tcp/127.0.0.1:0"],
        "--encoding: Invalid enum value 'png'",
    ),
    (
        "bench chain encoding",
        ["bench", "chain", "--encoding", "jpeg,png"],
        "--encoding: unknown png",
    ),
    ("bench chain runs", ["bench", "chain", "--runs", "0"], "--runs must be at least 1"),
    (
        "bench option the benchmark does not read",
        ["bench", "chain", "--head", "simhead16"],
        "--head: bench chain does not read it (bench robot does)",
    ),
    ("bench chain sched", ["bench", "chain", "--sched", "fifo"], "--sched: unknown fifo"),
    ("bench chain mode", ["bench", "chain", "--mode", "router"], "--mode: unknown router"),
    ("bench chain model", ["bench", "chain", "--models", "tiny"], "--models: unknown tiny"),
    ("bench chain layout", ["bench", "chain", "--layout", "shared"], "--layout: unknown shared"),
    ("bench fanout robots", ["bench", "fanout", "--robots", "a,b"], "--robots: not a list"),
    ("bench fanout no robots", ["bench", "fanout", "--robots", "0"], "counts of at least 1"),
    ("bench fanout layout", ["bench", "fanout", "--layout", "threads"], "unknown layout 'threads'"),
    (
        "bench drivers emulated frames",
        ["bench", "drivers", "--emulated", "--frames", "0"],
        "--frames must be at least 1",
    ),
    (
        "bench drivers emulated repeat",
        ["bench", "drivers", "--emulated", "--repeat", "0"],
        "--repeat must be at least 1",
    ),
    (
        "bench drivers emulated fps",
        ["bench", "drivers", "--emulated", "--fps", "0"],
        "--fps must be a positive number, not 0",
    ),
    (
        "bench fanout one model",
        ["bench", "fanout", "--models", "fast,full"],
        "--models: bench fanout takes one value",
    ),
    ("bench run runs", ["bench", "run", "--runs", "0"], "--runs must be at least 1"),
    ("bench run frames", ["bench", "run", "--frames", "443"], "so at most 442 after the 30"),
    ("bench run not a video", ["bench", "run", "{garbage.mp4}"], "not a video of more than 30"),
    (
        "bench run mediapipe without task",
        ["bench", "run", "--mediapipe-python", "python3"],
        "--mediapipe-python needs --mediapipe-task",
    ),
    (
        "bench run mediapipe python",
        ["bench", "run", "--mediapipe-python", "{bad.json}", "--mediapipe-task", "{bad.json}"],
        "not an executable file",
    ),
    ("robot name", ["translator", "--robot", "a/b"], "invalid robot name 'a/b'"),
    (
        "closed loop on a written profile",
        ["translator", "--robot-rig", "self", "--profile", "head16"],
        "--robot-rig: profile head16 is not learned",
    ),
    ("closed loop rig", ["translator", "--robot-rig", "a/b"], "invalid --robot-rig name 'a/b'"),
    (
        "loop state without a loop",
        ["translator", "--loop-state", "x.loop"],
        "--loop-state goes with --robot-rig or --robot-camera",
    ),
    (
        "closed loop two ways",
        ["translator", "--robot-rig", "self", "--robot-camera", "0"],
        "two ways to see the robot's face: give one",
    ),
    (
        "closed loop camera on a written profile",
        ["translator", "--robot-camera", "0", "--profile", "head16"],
        "--robot-camera: profile head16 is not learned",
    ),
    ("robot name in a graph", ["run", "{robotgraph.toml}"], "node t: invalid robot name"),
    ("unknown core", ["features", "--cpus", "4096"], "--cpus 4096: no core 4096 here"),
    ("nice range", ["features", "--nice", "30"], "--nice: Expected `int` <= 19"),
    ("realtime range", ["points", "--realtime", "0"], "--realtime: Expected `int` >= 1"),
    (
        "negative input age",
        ["points", "--max-input-age-s", "-1"],
        "--max-input-age-s: Expected `float` >= 0.0",
    ),
    (
        "NaN input age",
        ["features", "--max-input-age-s", "nan"],
        "--max-input-age-s: Expected `float` >= 0.0",
    ),
    (
        "input age in a graph",
        ["run", "{agegraph.toml}"],
        "node p: max_input_age_s: Expected `float` >= 0.0",
    ),
    ("router realtime range", ["router", "--realtime", "200"], "--realtime 200: must be within"),
    ("learn without a camera", ["learn", "--profile", "paper16", "--out", "s.mcap"], "--camera"),
    (
        "learn with a missing camera",
        ["learn", "--profile", "paper16", "--out", "s.mcap", "--camera", "9"],
        "cannot open camera 9",
    ),
    (
        "learn with a bad port",
        [
            "learn",
            "--profile",
            "paper16",
            "--out",
            "s.mcap",
            "--source",
            "video",
            "--driver",
            "maestro",
            "--port",
            "/nonexistent/tty",
        ],
        "/nonexistent/tty: cannot open it",
    ),
    (
        "learn with a bad profile",
        ["learn", "--profile", "{bad.toml}", "--out", "s.mcap", "--source", "video"],
        "bad.toml",
    ),
    (
        "learn no poses",
        ["learn", "--profile", "paper16", "--out", "s.mcap", "--source", "video", "--poses", "0"],
        "--poses must be at least 1",
    ),
    (
        "learn a stream counted in poses",
        [
            *("learn", "--profile", "paper16", "--out", "s.mcap", "--source", "video"),
            *("--plan", "stream", "--poses", "300"),
        ],
        "--plan stream babbles for --minutes (default 10), not a number of --poses",
    ),
    (
        "learn into a file that is not a session",
        ["learn", "--profile", "paper16", "--out", "{garbage.mp4}", "--source", "video"],
        "not a babbling session",
    ),
    ("learn without a session", ["learn", "--profile", "paper16"], "--out SESSION.mcap"),
    (
        "learn too fast",
        ["learn", "--profile", "paper16", "--out", "s.mcap", "--video", "x", "--pace", "2"],
        "the pace is a fraction of the profile's speeds",
    ),
    (
        "learn waits",
        ["learn", "--profile", "paper16", "--out", "s.mcap", "--video", "x", "--min-wait", "5"],
        "the settle waits need 0 <= minimum <= maximum",
    ),
    (
        "learn measured tolerance",
        [
            *("learn", "--profile", "paper16", "--out", "s.mcap", "--video", "x"),
            *("--measured-tolerance", "0"),
        ],
        "the settle tolerances must be positive",
    ),
    (
        "learn measured timeout",
        [
            *("learn", "--profile", "paper16", "--out", "s.mcap", "--video", "x"),
            *("--measured-timeout", "-1"),
        ],
        "the measured-position timeout must be positive",
    ),
    (
        "learn neutral too often",
        [
            "learn",
            "--profile",
            "paper16",
            "--out",
            "s.mcap",
            "--video",
            "x",
            "--neutral-every",
            "1",
        ],
        "a neutral pose at most every other pose",
    ),
    (
        "learn unknown plan",
        [
            *("learn", "--profile", "paper16", "--out", "s.mcap", "--video", "x"),
            *("--plan", "clever"),
        ],
        "--plan must be one of fixed, adaptive, stream, not 'clever'",
    ),
    (
        "learn resumed with another plan option",
        [
            *("learn", "--profile", "paper16", "--out", "{session.mcap}", "--video", "x"),
            *("--sweep-steps", "2"),
        ],
        "session.mcap was babbled with --sweep-steps 3: resume it with that value",
    ),
    ("learn without a profile", ["learn", "--out", "s.mcap"], "--profile"),
    ("learn fit a missing session", ["learn", "--fit-only", "nope.mcap"], "does not exist"),
    (
        "learn fit a file that is not a session",
        ["learn", "--fit-only", "{garbage.csv}"],
        "not a babbling session",
    ),
    (
        "hardware profile in T",
        ["translator", "--profile", "head16_hardware"],
        "profile head16_hardware has servos without a source (right_eyebrow",
    ),
    (
        "missing learned profile",
        ["translator", "--profile", "/nonexistent/robot.learned"],
        "profile file /nonexistent/robot.learned does not exist",
    ),
    (
        "learned profile of a later version",
        ["translator", "--profile", "{future.learned}"],
        "learned profile version 4 is not supported (this reads 1, 2, 3)",
    ),
    ("bench robot frames", ["bench", "robot", "--frames", "0"], "--frames must be at least 1"),
    ("bench robot profile", ["bench", "robot", "--profile", "robo9"], "robo9: no profile"),
    ("bench robot head", ["bench", "robot", "--head", "robo9"], "unknown head 'robo9'"),
    (
        "bench robot video",
        ["bench", "robot", "{garbage.mp4}", "--head", "simhead16", "--frames", "2"],
        "cannot open",
    ),
    ("bench robot json", ["bench", "robot", "--json", "."], "JSON . is a directory"),
    ("bench robot live camera", ["bench", "robot", "--driver", "maestro"], "both --driver and"),
    ("bench robot live port", ["bench", "robot", "--port", "/dev/x"], "--port goes with --driver"),
    (
        "bench robot live head",
        ["bench", "robot", "--driver", "maestro", "--camera", "0", "--head", "simhead16"],
        "--head names a simulated head",
    ),
    (
        "bench robot live driver",
        ["bench", "robot", "--driver-config", "{driver.toml}", "--camera", "0"],
        "teleporter",
    ),
    (
        "bench robot ros2 camera without driver",
        ["bench", "robot", "--ros2-image-topic", "/camera/image_raw"],
        "needs both --driver and --camera (or --ros2-image-topic)",
    ),
    (
        "bench robot two cameras",
        ["bench", "robot", "--driver", "maestro", "--camera", "0", "--ros2-image-topic", "/c"],
        "choose one source, not --camera and --ros2-image-topic",
    ),
    (
        "bench robot rig option without driver",
        ["bench", "robot", "--baud", "57600"],
        "--baud goes with --driver (a head outside this process)",
    ),
    (
        "bench robot option of another driver",
        ["bench", "robot", "--driver", "maestro", "--camera", "0", "--i2c-bus", "1"],
        "--i2c-bus does not apply to driver maestro",
    ),
    (
        "bench robot board not there",
        ["bench", "robot", "--driver", "dynamixel", "--port", "/nonexistent", "--camera", "0"],
        "/nonexistent: cannot open it",
    ),
    (
        "bench robot camera not live",
        ["bench", "robot", "--driver", "record", "--out", "/nonexistent/r.jsonl", "--ticks", "10"],
        "source ticks is not a live camera",
    ),
    (
        "bench chain rig option",
        ["bench", "chain", "--driver", "maestro"],
        "--driver: bench chain does not read it (bench robot does)",
    ),
    (
        "bench robot closed loop written",
        ["bench", "robot", "--closed-loop", "--profile", "head16"],
        "--closed-loop needs a learned --profile",
    ),
    (
        "bench robot closed loop live",
        ["bench", "robot", "--closed-loop", "--driver", "maestro", "--camera", "0"],
        "--closed-loop needs a learned --profile",
    ),
    (
        "bench robot planned written",
        ["bench", "robot", "--planned", "--profile", "head16"],
        "--planned needs a learned --profile (e.g. runs/head.learned) or --learn-poses (it "
        "plays plans to learned profiles only)",
    ),
    (
        "bench robot planned live",
        ["bench", "robot", "--planned", "--driver", "maestro", "--camera", "0"],
        "--planned needs a learned --profile",
    ),
    (
        "bench planned elsewhere",
        ["bench", "chain", "--planned"],
        "--planned",
    ),
    (
        "bench robot malformed seed",
        ["bench", "robot", "--head", "seed:-1"],
        "head 'seed:-1': the seed must be a whole number within 0..4294967295 (e.g. seed:7)",
    ),
    (
        "bench robot generated seed too large",
        ["bench", "robot", "--head", "generated:4294967296"],
        "head 'generated:4294967296': the seed must be a whole number",
    ),
    ("bench robot learn poses", ["bench", "robot", "--learn-poses", "5"], "at least 60 (got 5)"),
    (
        "bench robot learn live",
        ["bench", "robot", "--learn-poses", "100", "--driver", "maestro", "--camera", "0"],
        "--learn-poses babbles the simulated heads in process",
    ),
    (
        "bench robot missing calibration",
        ["bench", "robot", "--calibration", "/nonexistent/alice.json"],
        "--calibration: calibration file /nonexistent/alice.json does not exist",
    ),
    (
        "bench robot broken calibration",
        ["bench", "robot", "--calibration", "{bad.json}"],
        "bad.json: JSON is malformed",
    ),
    (
        "bench fidelity calibration",
        ["bench", "fidelity", "--calibration", "alice"],
        "--calibration: bench fidelity does not read it (its faces are synthetic",
    ),
    (
        "bench smoothing calibration",
        ["bench", "smoothing", "--calibration", "alice"],
        "--calibration: bench smoothing does not read it (it feeds T synthetic features",
    ),
    ("render robot head", ["render", "--robot-head", "robo9", "--out", "x.mp4"], "'robo9'"),
    (
        "render robot bars",
        ["render", "--robot-head", "simhead16", "--bars", "paper16", "--out", "x.mp4"],
        "--bars takes only none",
    ),
    (
        "render closed loop without a head",
        ["render", "--closed-loop", "--out", "x.mp4"],
        "--closed-loop drives a simulated head: give --robot-head HEAD",
    ),
    (
        "render closed loop on a written profile",
        [
            *("render", "--robot-head", "simhead16", "--profile", "head16"),
            *("--closed-loop", "--out", "x.mp4"),
        ],
        "profile head16 is not learned: no closed loop",
    ),
    (
        "simhead unknown head",
        ["simhead", "nohead", "--serial-link", "tty"],
        "unknown head 'nohead'",
    ),
    ("simhead bad head file", ["simhead", "{bad.toml}", "--serial-link", "tty"], "not valid TOML"),
    (
        "simhead malformed seed",
        ["simhead", "seed:x", "--serial-link", "tty"],
        "head 'seed:x': the seed must be a whole number",
    ),
    (
        "render robot malformed seed",
        ["render", "--robot-head", "seed:", "--out", "x.mp4"],
        "head 'seed:': the seed must be a whole number",
    ),
    ("simhead address", ["simhead", "--serial-link", "tty", "--http", "8090"], "is not HOST:PORT"),
    (
        "simhead link over a file",
        ["simhead", "--serial-link", "{bad.toml}", "--http", "127.0.0.1:0"],
        "exists and is not a symlink",
    ),
    ("simhead fps", ["simhead", "--serial-link", "tty", "--fps", "0"], "--fps 0 is not within"),
    ("simhead noise", ["simhead", "--serial-link", "tty", "--noise", "-1"], "--noise -1 is not"),
    ("simhead without a link", ["simhead"], "simhead needs --serial-link PATH"),
    ("simhead bench", ["simhead", "--bench", "-1"], "--bench -1: give at least 1 frame"),
    (
        "simhead device number",
        ["simhead", "--serial-link", "tty", "--device-number", "300"],
        "device number 300 is not in 0..127",
    ),
    ("console without a profile", ["console", "--driver", "virtual"], "console needs --profile"),
    ("console without a driver", ["console", "--profile", "head16"], "console needs --driver NAME"),
    (
        "console page address",
        ["console", "--profile", "head16", "--driver", "virtual", "--page", "8095"],
        "--page '8095' is not HOST:PORT",
    ),
    (
        "console unknown profile",
        ["console", "--profile", "nohead", "--driver", "virtual"],
        "no profile named 'nohead'",
    ),
    (
        "console bad profile file",
        ["console", "--profile", "{bad.toml}", "--driver", "virtual"],
        "not valid TOML",
    ),
    (
        "console save to a non-profile",
        ["console", "--profile", "head16", "--driver", "virtual", "--save", "head.json"],
        "--save head.json: a profile file ends in .toml",
    ),
    (
        "console save into a folder",
        ["console", "--profile", "head16", "--driver", "virtual", "--save", "{a-folder}"],
        "a profile file ends in .toml",
    ),
    (
        "console face page",
        ["console", "--profile", "head16", "--driver", "virtual", "--face-page", "host:8090"],
        "--face-page 'host:8090': give an http:// or https:// address",
    ),
    (
        "console calibration source",
        ["console", "--profile", "head16", "--driver", "virtual", "--camera", "front"],
        "--camera 'front': expected a device index",
    ),
    (
        "console driver that cannot show the profile",
        ["console", "--profile", "paper16", "--driver", "vmc"],
        "the vmc driver cannot show 15 of the 16 controls of profile paper16",
    ),
    (
        "console schedule without a video",
        ["console", "--profile", "head16", "--driver", "virtual", "--schedule", "neutral=0-2"],
        "--schedule needs --video FILE (or --camera N): without one the console cannot",
    ),
    (
        "console schedule without neutral",
        [
            "console",
            "--profile",
            "head16",
            "--driver",
            "virtual",
            "--video",
            "{garbage.mp4}",
            "--schedule",
            "smile=0-2",
        ],
        "the schedule needs a neutral step",
    ),
    (
        "run renders a looping video",
        ["run", "--loop", "--max-frames", "2", "--render", "o.mp4", "--out", "x"],
        "a looping video never ends",
    ),
    ("camera name", ["sensor", "--camera", "front"], "--camera 'front': expected a device index"),
    ("camera file", ["sensor", "--camera", "{garbage.mp4}"], "a file, not a camera (use --video"),
    ("camera scheme", ["sensor", "--camera", "ftp://cam/x"], "--camera ftp://cam/x: cannot stream"),
    (
        "ros2 output",
        ["control", "--driver", "ros2", "--ros2-output", "pose"],
        "driver ros2: --ros2-output: Invalid enum value 'pose'",
    ),
    ("ros2 depth", ["control", "--driver", "ros2", "--ros2-depth", "0"], "--ros2-depth"),
    (
        "ros2 image type",
        ["sensor", "--ros2-image-topic", "/cam", "--ros2-image-type", "jpeg"],
        "--ros2-image-type: Invalid enum value 'jpeg'",
    ),
    (
        "plan a written profile",
        ["plan", "x.mp4", "--profile", "head16", "--out", "p.mcap"],
        "profile head16 is not learned (facesynth learn writes one)",
    ),
    (
        "plan over a file",
        ["plan", "x.mp4", "--profile", "head16", "--out", "{bad.toml}"],
        "exists (a plan is never written over)",
    ),
    (
        "plan into no folder",
        ["plan", "x.mp4", "--profile", "head16", "--out", "{a-folder}/no/more/p.mcap"],
        "does not exist",
    ),
    (
        "plan amplitude",
        ["plan", "x.mp4", "--profile", "head16", "--out", "p.mcap", "--amplitude", "-1"],
        "--amplitude must be within 0..100 (got -1)",
    ),
    (
        "plan lead",
        ["plan", "x.mp4", "--profile", "head16", "--out", "p.mcap", "--lead", "1e9"],
        "--lead must be within 0..100",
    ),
    (
        "plan robot name",
        ["plan", "x.mp4", "--profile", "head16", "--out", "p.mcap", "--robot", "a/b"],
        "invalid robot name 'a/b': use 1-64 letters",
    ),
    (
        "plan driver without camera",
        ["plan", "x.mp4", "--profile", "head16", "--out", "p.mcap", "--driver", "maestro"],
        "a rehearsal on the robot needs both --driver and --camera",
    ),
    (
        "plan rounds without robot",
        ["plan", "x.mp4", "--profile", "head16", "--out", "p.mcap", "--rounds", "2"],
        "--rounds is for a rehearsal on the robot, which needs --driver and --camera",
    ),
    (
        "plan camera without driver",
        ["plan", "x.mp4", "--profile", "head16", "--out", "p.mcap", "--camera", "0"],
        "--camera is for a rehearsal on the robot, which needs --driver and --camera",
    ),
    (
        "plan another driver's option",
        [
            *("plan", "x.mp4", "--profile", "head16", "--out", "p.mcap"),
            *("--driver", "maestro", "--camera", "0", "--i2c-bus", "1"),
        ],
        "--i2c-bus does not apply to driver maestro",
    ),
    (
        "plan no rounds",
        [
            *("plan", "x.mp4", "--profile", "head16", "--out", "p.mcap"),
            *("--driver", "maestro", "--camera", "0", "--rounds", "0"),
        ],
        "--rounds must be at least 1 (got 0)",
    ),
    (
        "plan look every 0",
        [
            *("plan", "x.mp4", "--profile", "head16", "--out", "p.mcap"),
            *("--driver", "maestro", "--camera", "0", "--look-every", "0"),
        ],
        "--look-every must be at least 1 (got 0)",
    ),
    (
        "rosbag2 from landmarks",
        ["convert", "{garbage.csv}", "--to", "rosbag2", "out"],
        "--to rosbag2 converts a recording (.mcap)",
    ),
]


@pytest.mark.parametrize(("argv", "expected"), [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_input_gives_one_clear_error(
    argv: list[str],
    expected: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.chdir(tmp_path)  # relative outputs ("--out x") land here, not in the checkout
    files = _files(tmp_path)
    argv = [re.sub(r"\{([^}]+)\}", lambda m: files[m.group(1)].as_posix(), a) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"facesynth {argv[0]}: error: " in err
    assert expected in err
    assert "Traceback" not in err


def test_bad_rig_is_named(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert (
        main(
            [
                "sensor",
                "--ticks",
                "2",
                "--rig",
                "a/b",
                "--mode",
                "router",
                "--listen",
                "tcp/127.0.0.1:0",
            ]
        )
        == 2
    )
    assert "invalid rig name 'a/b'" in capsys.readouterr().err


@pytest.mark.parametrize("command", ["points", "run", "track"])
def test_model_choices_come_from_the_registry(
    command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main([command, "--help"])
    assert exit_info.value.code == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "--model" in out and "Face Landmarker v2" in out and "fast" in out


def test_track_refuses_an_unknown_model(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        build_parser().parse_args(["track", "v.mp4", "--out", "x", "--model", "huge"])
    assert exit_info.value.code == 2
    assert "invalid choice: 'huge'" in capsys.readouterr().err


def test_profile_check_and_list(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["profile", "check", "paper16"]) == 0
    assert "paper16: ok (16 servos)" in capsys.readouterr().out
    assert main(["profile", "list"]) == 0
    assert "paper16" in capsys.readouterr().out.split()


def test_rig_defaults_from_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FACESYNTH_RIG", "lab2")
    assert build_parser().parse_args(["features"]).rig == "lab2"


def test_a_taken_page_port_is_one_error_line(capsys: pytest.CaptureFixture[str]) -> None:
    import socket

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        address = f"127.0.0.1:{taken.getsockname()[1]}"
        argv = [
            "run",
            "--profile",
            "virtual",
            "--driver",
            "virtual",
            "--http",
            address,
            "--ticks",
            "3",
            "--openface-csv",
            "facesynth/app/data/OpenFace_Test.csv",
            "--listen",
            "tcp/127.0.0.1:0",
        ]
        assert main(argv) == 2  # a usage error: another --http fixes it (issue 20)
    err = capsys.readouterr().err
    assert f"facesynth run: error: cannot serve the live face page on {address}" in err
    assert "choose another address with --http HOST:PORT" in err
    assert "Traceback" not in err


def test_a_taken_console_page_port_is_one_error_line(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    import socket

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        address = f"127.0.0.1:{taken.getsockname()[1]}"
        argv = ["console", "--profile", "head16", "--driver", "record", "--out",
                str(tmp_path / "c.jsonl"), "--page", address, "--listen", "tcp/127.0.0.1:0",
                "--save", str(tmp_path / "head16.toml"), "--rig", "taken"]  # fmt: skip
        assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"facesynth console: error: --page {address}: cannot listen there" in err
    assert "Traceback" not in err


# Issue 20 (what a new user hit on a fresh clone): its rows, in a block of their own.

NEW_USER_CASES = [
    ("unknown graph name", ["run", "nosuch"], "graph nosuch does not exist (bundled graphs: demo"),
    (
        "wait-for typo",
        ["sensor", "--wait-for", "points,pionts", "--ticks", "1"],
        "--wait-for: no service 'pionts' (did you mean points? services: sensor, points,",
    ),
    (
        "replay wait-for typo",
        ["replay", "x.mcap", "--wait-for", "featuers"],
        "--wait-for: no service 'featuers' (did you mean features?",
    ),
    (
        "out two folders deep",
        ["control", "--driver", "record", "--out", "new/deeper/c.jsonl"],
        "cannot write record file new/deeper/c.jsonl: folder new does not exist",
    ),
    (
        "render two folders deep",
        ["render", "--out", "new/deeper/o.mp4"],
        "cannot write video new/deeper/o.mp4: folder new does not exist",
    ),
    (
        "run --render two folders deep",
        ["run", "--render", "new/deeper/o.mp4", "--ticks", "1"],
        "folder new does not exist",
    ),
]


@pytest.mark.parametrize(
    ("argv", "expected"), [c[1:] for c in NEW_USER_CASES], ids=[c[0] for c in NEW_USER_CASES]
)
def test_new_user_mistakes_give_one_clear_error(
    argv: list[str],
    expected: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    test_bad_input_gives_one_clear_error(argv, expected, tmp_path, capsys, monkeypatch)


@pytest.mark.parametrize("command", ["run", "render"])
def test_help_lists_the_bundled_graphs(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main([command, "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "a bundled graph by name (demo: " in out and "; face: " in out


def _closed_port() -> int:
    import socket

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def test_record_without_a_router_leaves_no_empty_session(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "x.mcap"
    connect = f"tcp/127.0.0.1:{_closed_port()}"
    argv = ["record", "--out", str(out), "--connect", connect, "--router-timeout", "0"]
    assert main(argv) == 2
    assert "facesynth record: error: cannot open a Zenoh client session" in capsys.readouterr().err
    assert not out.exists()


def test_a_taken_foxglove_port_names_the_flag(capsys: pytest.CaptureFixture[str]) -> None:
    import socket

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        address = f"127.0.0.1:{taken.getsockname()[1]}"
        argv = ["run", "--foxglove", address, "--ticks", "3", "--listen", "tcp/127.0.0.1:0"]
        argv += ["--openface-csv", str(sample_openface_csv())]
        assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"facesynth run: error: cannot serve Foxglove on {address}" in err
    assert "choose another address with --foxglove HOST:PORT" in err and "Traceback" not in err


def test_a_busy_router_port_names_the_flag(capsys: pytest.CaptureFixture[str]) -> None:
    import socket

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        endpoint = f"tcp/127.0.0.1:{taken.getsockname()[1]}"
        assert main(["router", "--listen", endpoint]) == 2
    err = capsys.readouterr().err
    assert f"facesynth router: error: cannot open a Zenoh router session ({endpoint})" in err
    assert "Address already in use" in err and "--listen" in err and ".rs:" not in err


@pytest.mark.parametrize(
    ("argv", "usage", "error"),
    [
        (
            ["run", "--profle", "virtual"],
            "usage: facesynth run ",
            "facesynth run: error: unrecognized arguments: --profle (did you mean --profile?)",
        ),
        (
            ["sensor", "--vidoe=x.mp4"],
            "usage: facesynth sensor ",
            "unrecognized arguments: --vidoe=x.mp4 (did you mean --video?)",
        ),
        (
            ["control", "--qwerty"],
            "usage: facesynth control ",
            "facesynth control: error: unrecognized arguments: --qwerty\n",
        ),
    ],
)
def test_a_misspelt_flag_shows_its_commands_usage_and_a_suggestion(
    argv: list[str], usage: str, error: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith(usage) and error in err


def test_the_foxglove_address_is_said_once(
    capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    import logging

    argv = ["run", "--foxglove", "127.0.0.1:0", "--ticks", "3", "--listen", "tcp/127.0.0.1:0"]
    argv += ["--openface-csv", str(sample_openface_csv()), "--out", "/dev/null"]
    with caplog.at_level(logging.INFO):
        assert main(argv) == 0
    said = capsys.readouterr().out + "\n".join(r.getMessage() for r in caplog.records)
    assert said.count("ws://127.0.0.1:") == 1, said


def _help(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    with pytest.raises(SystemExit):
        main([*argv, "--help"])
    return " ".join(capsys.readouterr().out.split())


@pytest.mark.parametrize("command", ["run", "sensor", "points", "control", "render"])
def test_help_says_nothing_twice(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    """Issue 20: `camera: camera: requested width`, summaries cut at a line break, `.;`."""
    text = _help([command], capsys)
    assert not re.search(r"\b(\w+): \1: ", text), "a plugin's name said twice"
    assert ".;" not in text and "and the;" not in text
    if command in ("run", "points"):
        whole = (
            "track: Replay of a ``facesynth track`` JSON-lines file (mesh, iris and 68-point "
            "views, and the blendshapes when the file has them);"
        )
        assert whole in text


def test_list_drivers_says_each_default_once(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["control", "--list-drivers"]) == 0
    out = capsys.readouterr().out
    assert "pages open at once (default 16)\n" in out
    assert not re.search(r"\(default ([^()]*)\) \(default \1\)", out)
    assert "(default 127.0.0.1:8080; port 0 = any free port)\n" in out


def test_profile_show_has_a_header(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["profile", "show", "paper16"]) == 0
    header, first = capsys.readouterr().out.splitlines()[:2]
    assert header.split() == ["ch", "servo", "min_us", "neutral", "max_us", "reversed", "source"]
    assert first.split()[:5] == ["0", "right_eyebrow", "1000", "1500", "2000"]


async def _mjpeg_cases(request: web.Request) -> web.StreamResponse:
    """A camera server answering each way the sensor refuses: by the request's path."""
    if request.path == "/no-boundary.mjpg":
        return web.Response(body=b"", headers={"Content-Type": "multipart/x-mixed-replace"})
    if request.path != "/wrong-boundary.mjpg":
        raise web.HTTPNotFound()
    response = web.StreamResponse(
        headers={"Content-Type": "multipart/x-mixed-replace; boundary=frame"}
    )
    await response.prepare(request)
    await response.write(b"--other\r\nContent-Length: 0\r\n\r\n\r\n")
    return response


@pytest.fixture
def camera_server() -> Iterator[str]:
    """``http://127.0.0.1:PORT``: :func:`_mjpeg_cases` served from a thread of its own."""
    loop = asyncio.new_event_loop()
    app = web.Application()
    app.router.add_get("/{name}", _mjpeg_cases)
    runner = web.AppRunner(app)
    loop.run_until_complete(runner.setup())
    site = web.TCPSite(runner, "127.0.0.1", 0)
    loop.run_until_complete(site.start())
    port = runner.addresses[0][1]
    thread = threading.Thread(target=loop.run_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{port}"
    finally:
        asyncio.run_coroutine_threadsafe(runner.cleanup(), loop).result(timeout=10)
        loop.call_soon_threadsafe(loop.stop)
        thread.join(timeout=10)
        loop.close()


@pytest.mark.parametrize(
    ("path", "expected"),
    [
        ("/gone.mjpg", "cannot open the camera stream {url} (HTTP 404 Not Found)"),
        ("/no-boundary.mjpg", "camera:{url}: not an MJPEG stream: the multipart content type"),
        (
            "/wrong-boundary.mjpg",
            "camera:{url}: not an MJPEG stream: expected the boundary '--frame', got '--other'",
        ),
    ],
)
def test_a_camera_url_that_is_not_mjpeg_is_one_error_line(
    path: str, expected: str, camera_server: str, capsys: pytest.CaptureFixture[str]
) -> None:
    url = camera_server + path
    argv = ["sensor", "--camera", url, "--mode", "peer", "--listen", "tcp/127.0.0.1:0"]
    argv += ["--wait-timeout", "0"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"facesynth sensor: error: {expected.format(url=url)}" in err
    assert "Traceback" not in err


LIBRARY_CHATTER = ("XNNPACK", "[ WARN:", "[ INFO:", "[h264 @")
# A camera index no machine of this kind has; "run" also loads the tracker (LiteRT) first.
CHATTY_ERRORS = [
    ("sensor", ["sensor", "--camera", "97"]),
    ("run", ["run", "--camera", "97", "--out", "x.jsonl", "--listen", "tcp/127.0.0.1:0"]),
]


def _facesynth(argv: list[str], folder: Path) -> subprocess.CompletedProcess[str]:
    """``python -m facesynth ARGV`` as a real process, without OpenCV settings of the caller."""
    env = {k: v for k, v in os.environ.items() if "OPENCV" not in k}
    command = [sys.executable, "-m", "facesynth", *argv]
    return subprocess.run(command, cwd=folder, env=env, capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize(("command", "argv"), CHATTY_ERRORS, ids=[c[0] for c in CHATTY_ERRORS])
def test_a_one_line_error_is_the_only_line(command: str, argv: list[str], tmp_path: Path) -> None:
    """Without --log-level DEBUG, OpenCV's and LiteRT's own lines stay out of the terminal."""
    done = _facesynth(argv, tmp_path)
    assert done.returncode == 2
    assert done.stderr == f"facesynth {command}: error: cannot open camera 97\n"


@pytest.mark.parametrize(("command", "argv"), CHATTY_ERRORS, ids=[c[0] for c in CHATTY_ERRORS])
def test_library_chatter_is_shown_with_log_level_debug(
    command: str, argv: list[str], tmp_path: Path
) -> None:
    done = _facesynth([*argv, "--log-level", "DEBUG"], tmp_path)
    assert done.returncode == 2
    assert done.stderr.splitlines()[-1] == f"facesynth {command}: error: cannot open camera 97"
    assert "[ WARN:" in done.stderr  # OpenCV: the camera index does not open
    if command == "run":  # LiteRT's line, as a DEBUG log line of the runtime that made it
        assert "litert DEBUG INFO: Created TensorFlow Lite XNNPACK delegate" in done.stderr


def test_a_truncated_video_is_one_line_without_ffmpeg_lines(tmp_path: Path) -> None:
    video = sample_video().read_bytes()
    (tmp_path / "short.mp4").write_bytes(video[: len(video) // 20])
    done = _facesynth(["track", "short.mp4", "--out", "t.jsonl"], tmp_path)
    assert done.returncode == 2
    assert done.stderr.startswith("facesynth track: error: video truncated or corrupt")
    assert len(done.stderr.splitlines()) == 1
    assert not any(chatter in done.stderr for chatter in LIBRARY_CHATTER)


# Issue 29: how commands meet their router (facesynth.app.router_wait), in a block of their own.

NO_ROUTER = "tcp/127.0.0.1:9"  # nothing listens on loopback's discard port: refused at once
ROUTER_CASES = [
    (
        "status, no router, no wait",
        ["status", "--connect", NO_ROUTER, "--router-timeout", "0"],
        f"cannot open a Zenoh client session ({NO_ROUTER}): ",
    ),
    (
        "record, no router, no wait",
        ["record", "--out", "s.mcap", "--connect", NO_ROUTER, "--router-timeout", "0"],
        "start one with: facesynth router; or --connect another",
    ),
    (
        "inspect, no router, no wait",
        ["inspect", "--foxglove", "127.0.0.1:0", "--connect", NO_ROUTER, "--router-timeout", "0"],
        f"cannot open a Zenoh client session ({NO_ROUTER}): ",
    ),
    (
        "status, no router within 1 s",
        ["status", "--connect", NO_ROUTER, "--router-timeout", "1"],
        "none answered within 1 s, --router-timeout S waits longer",
    ),
]


@pytest.mark.parametrize(
    ("argv", "expected"), [c[1:] for c in ROUTER_CASES], ids=[c[0] for c in ROUTER_CASES]
)
def test_no_router_gives_one_clear_error(
    argv: list[str],
    expected: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    test_bad_input_gives_one_clear_error(argv, expected, tmp_path, capsys, monkeypatch)


def test_a_one_shot_tool_waits_its_default_then_fails(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """replay (a one-shot tool) waits 2 s for its router by default, then one line, exit 2."""
    import time

    from facesynth.app.recording.convert import landmarks_to_mcap

    session = tmp_path / "points.mcap"
    landmarks_to_mcap(sample_openface_csv(), session)
    started = time.monotonic()
    assert main(["replay", str(session), "--connect", NO_ROUTER, "--log-level", "ERROR"]) == 2
    assert time.monotonic() - started >= 2.0
    err = capsys.readouterr().err
    assert err.startswith(
        f"facesynth replay: error: cannot open a Zenoh client session ({NO_ROUTER})"
    )
    assert "none answered within 2 s" in err and len(err.splitlines()) == 1


def test_health_without_a_router_is_unhealthy_after_router_timeout(
    capsys: pytest.CaptureFixture[str],
) -> None:
    argv = ["health", "--router", "--connect", NO_ROUTER, "--router-timeout", "0.5"]
    assert main(argv) == 1  # a health check: 1, whatever the reason
    out = capsys.readouterr().out
    assert out.startswith("unhealthy: cannot open a Zenoh client session")
    assert "none answered within 0.5 s" in out


def test_run_keeps_an_explicit_listen_it_cannot_have(capsys: pytest.CaptureFixture[str]) -> None:
    """run's default endpoint falls back to a free port; one given with --listen does not
    (other hosts may be told it): one line, exit 2, as facesynth doctor says (fix router)."""
    import socket

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        endpoint = f"tcp/127.0.0.1:{taken.getsockname()[1]}"
        argv = ["run", "--listen", endpoint, "--openface-csv", str(sample_openface_csv())]
        assert main([*argv, "--out", os.devnull]) == 2
    err = capsys.readouterr().err
    assert f"facesynth run: error: cannot open a Zenoh router session ({endpoint})" in err
    assert "Address already in use" in err and "Traceback" not in err


# Issue 26: a smart servo bus that does not match the profile (the emulated Dynamixel bus).

BUS_PROFILE = """name = "bus2"
[bus]
baud = 1000000
[[servos]]
name = "jaw"
channel = 0
bus_id = 1
model = "{model}"
min_us = 1000
neutral_us = 1500
max_us = 2000
[[servos]]
name = "brow"
channel = 1
bus_id = 2
min_us = 1000
neutral_us = 1500
max_us = 2000
"""


@pytest.mark.parametrize(
    ("ids", "model", "expected"),
    [
        (
            [1, 2],
            "XM430-W350",
            "servo 'jaw' (id 1) is a XL430-W250 (model number 1060), but profile 'bus2' "
            "expects a XM430-W350",
        ),
        ([1], "XL430-W250", "servo 'brow' (id 2) does not answer on "),
    ],
    ids=["model number wrong", "servo missing"],
)
def test_a_bus_that_does_not_match_the_profile_is_one_error_line(
    ids: list[int], model: str, expected: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sys.path.insert(0, str(Path(__file__).parent / "control"))
    from fake_devices.dynamixel import FakeDynamixelBus

    profile = tmp_path / "bus2.toml"
    profile.write_text(BUS_PROFILE.format(model=model))
    bus = FakeDynamixelBus(tmp_path / "ttyDXL", ids)
    bus.plug()
    try:
        argv = ["control", "test", "--servo", "jaw", "--driver", "dynamixel",
                "--port", str(bus.link), "--profile", str(profile)]  # fmt: skip
        assert main(argv) == 2
    finally:
        bus.close()
    err = capsys.readouterr().err
    assert f"facesynth control: error: {expected}" in err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize(
    ("argv", "plugin"),
    [
        (["control", "--driver", "ros2", "--profile", "paper16"], "ros2 driver"),
        (["sensor", "--ros2-image-topic", "/camera/image_raw"], "ros2 source"),
    ],
    ids=["driver", "source"],
)
def test_ros2_without_its_extra_is_one_line(
    argv: list[str],
    plugin: str,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setitem(sys.modules, "rclpy", None)  # import rclpy: ImportError, as without it
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.strip().splitlines()[-1] == (
        f"facesynth {argv[0]}: error: the {plugin} needs ROS 2 (rclpy), which is not "
        "installed: pip install 'facesynth[ros2]'"
    )
    assert "Traceback" not in err
