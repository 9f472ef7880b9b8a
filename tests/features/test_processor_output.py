"""services.features.core: F's output on a few real faces, held to what it gave before.

``processor_expected.json`` holds the Features messages F gave, on the frames below, at
c97b484, before F's CPU cut (issue 28: the same arithmetic with less numpy overhead, not
different maths): three neutral frames of the sample video's face (``synthetic_face``), then a
turned smiling head, raised brows with the eyes looking left, an open jaw under a roll, a wink,
a frame without a face and one whose mesh has no depth, each with its 52 blendshape scores,
through a plain processor and one with ``auto_range``. Every value must stay within 1e-9
(on the machine that wrote the file they stay bit for bit). ``write_expected`` wrote the file
(not run by the tests); rewrite it only for a change meant to change F's output, and say so.
"""

from __future__ import annotations

from pathlib import Path

import msgspec
import numpy as np
import pytest
from synthetic_face import IRIS, MESH, look_3d, move, points_message, transform

from facesynth.runtime import blendshapes
from facesynth.runtime.atomic import write_atomic
from facesynth.schemas.messages import Features, Points, ScoreSet
from facesynth.services.features.core import FeatureProcessor

EXPECTED = Path(__file__).with_name("processor_expected.json")
FRAME_NS = 40_000_000  # 25 fps
NEUTRAL_SECONDS = 0.1  # the first three frames

_BROWS = (70, 63, 105, 66, 107, 46, 53, 52, 65, 55, 300, 293, 334, 296, 336, 276, 283, 282, 295)
_CHIN = (152, 148, 377, 176, 400)
_LOWER_LIP = (87, 14, 317, 17, 84, 314)
_RIGHT_UPPER_LID = (160, 159, 158, 161, 157)


def _scores(seq: int) -> ScoreSet:
    """52 blendshape scores in 0..1, brows and eyes at rest, different each frame."""
    values = np.random.default_rng(seq).uniform(0.0, 0.15, blendshapes.COUNT)
    return ScoreSet(scheme=blendshapes.BLENDSHAPES52, values=values.tolist())


def _faces() -> list[tuple[np.ndarray | None, np.ndarray | None, int]]:
    """(mesh, iris, mesh dims) per frame; None: no face."""
    neutral = [
        transform(MESH, IRIS, yaw=y, pitch=p, shift=(d, -d, 0.0))
        for y, p, d in [(0.0, 0.0, 0.0), (1.5, -1.0, 2.0), (-1.0, 0.5, -3.0)]
    ]
    smile = move(move(MESH, (61,), -0.05, 0.04), (291,), 0.05, 0.04)
    brows = move(MESH, _BROWS, 0.0, 0.06)
    jaw = move(move(MESH, _CHIN, 0.0, -0.12), _LOWER_LIP, 0.0, -0.08)
    wink = move(MESH, _RIGHT_UPPER_LID, 0.0, -0.06)
    return [
        *((mesh, iris, 3) for mesh, iris in neutral),
        (*transform(smile, IRIS, yaw=18.0, pitch=-7.0, roll=4.0), 3),
        (*transform(brows, look_3d(MESH, IRIS, "left", 0.06, 0.02), scale=1.3), 3),
        (*transform(jaw, IRIS, roll=-10.0, shift=(15.0, 5.0, 0.0)), 3),
        (wink, look_3d(MESH, IRIS, "right", -0.05, 0.0), 3),
        (None, None, 3),
        (smile, IRIS, 2),
    ]


def frames() -> list[Points]:
    """The Points messages of the frames above."""
    out = []
    for seq, (mesh, iris, dims) in enumerate(_faces()):
        t = seq * FRAME_NS
        if mesh is None:
            out.append(points_message(None, None, seq=seq, t_media_ns=t, face=False))
            continue
        message = points_message(mesh, iris, seq=seq, t_media_ns=t, mesh_dims=dims)
        out.append(msgspec.structs.replace(message, scores=[_scores(seq)]))
    return out


def outputs() -> dict[str, list[Features]]:
    """F's output on :func:`frames`, plain and with ``auto_range``."""
    runs = {}
    for name, auto in (("plain", False), ("auto_range", True)):
        processor = FeatureProcessor(neutral_seconds=NEUTRAL_SECONDS, auto_range=auto)
        runs[name] = [processor.process(points) for points in frames()]
    return runs


def write_expected(path: Path = EXPECTED) -> None:
    """Write :func:`outputs` to ``path``, a message a line (not run by the tests; see the
    module doc)."""
    runs = [
        f'"{name}": [\n' + ",\n".join(msgspec.json.encode(f).decode() for f in run) + "\n]"
        for name, run in outputs().items()
    ]
    write_atomic(path, "{\n" + ",\n".join(runs) + "\n}\n", mode=0o644)


@pytest.fixture(scope="module")
def expected() -> dict[str, list[Features]]:
    return msgspec.json.decode(EXPECTED.read_bytes(), type=dict[str, list[Features]])


@pytest.fixture(scope="module")
def got() -> dict[str, list[Features]]:
    return outputs()


def test_the_frames_cover_what_f_reads(expected) -> None:
    plain = expected["plain"]
    assert [f.face for f in plain] == [True] * 7 + [False, True]
    assert [bool(f.named) for f in plain] == [False] * 3 + [True] * 4 + [False, False]
    assert {"head_yaw", "gaze_left_x", "browInnerUp"} <= set(plain[3].named)
    assert plain[3].named["head_yaw"] > 0.5 and plain[5].raw["jaw_open"] > 0.05


@pytest.mark.parametrize("run", ["plain", "auto_range"])
def test_features_are_what_f_gave_before(expected, got, run: str) -> None:
    for out, want in zip(got[run], expected[run], strict=True):
        assert (out.seq, out.face, out.neutral_ready) == (want.seq, want.face, want.neutral_ready)
        for field in ("distances", "deltas", "displacements"):
            np.testing.assert_allclose(
                getattr(out, field), getattr(want, field), rtol=0, atol=1e-9, err_msg=field
            )
        for field in ("named", "raw"):
            values, wanted = getattr(out, field), getattr(want, field)
            assert list(values) == list(wanted), field
            for key, value in wanted.items():
                assert values[key] == pytest.approx(value, rel=0, abs=1e-9), (field, key)
