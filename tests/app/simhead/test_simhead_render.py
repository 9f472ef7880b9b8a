"""The simulated head's renderer: fast, faithful at rest, each effect where it belongs."""

from __future__ import annotations

import json
import time
from pathlib import Path

import cv2
import numpy as np
import pytest

from facesynth.app.simhead import EFFECTS, SimHead, load_head
from facesynth.app.simhead.photo import PhotoError, bundled_face, load_face
from facesynth.app.simhead.renderer import Renderer, default_renderer

MS = 1_000_000


@pytest.fixture(scope="module")
def renderer() -> Renderer:
    return default_renderer()


def test_at_rest_it_is_the_photo(renderer: Renderer) -> None:
    face = bundled_face()
    image = renderer.render({})
    assert image.shape == (320, 320, 3) and image.dtype == np.uint8
    assert np.abs(image.astype(int) - face.image).mean() < 1.0
    np.testing.assert_array_equal(renderer.landmarks({}), face.points[:, :2])


def test_a_frame_takes_a_few_ms(renderer: Renderer) -> None:
    busy = {name: 0.7 if i % 2 else -0.7 for i, name in enumerate(EFFECTS)}
    renderer.render(busy)
    # CPU time, not wall time: a loaded machine (other jobs, nice 19) stretched the wall clock
    # past 25 ms a frame (40 ms measured) with the renderer unchanged
    start = time.process_time()
    for _ in range(20):
        renderer.render(busy)
    per_frame = (time.process_time() - start) / 20
    assert per_frame < 0.025  # goal 20 ms; measured ~2-3 ms on one core


@pytest.mark.parametrize("effect", EFFECTS)
def test_each_effect_moves_its_own_side_of_the_face(renderer: Renderer, effect: str) -> None:
    rest = renderer.render({}).astype(np.int16)
    for direction in (1.0, -1.0):
        diff = np.abs(renderer.render({effect: direction}).astype(np.int16) - rest).sum(axis=2)
        moved = renderer.landmarks({effect: direction}) - renderer.landmarks({})
        if direction < 0 and not np.abs(moved).any() and not effect.startswith("gaze"):
            assert diff.max() == 0  # a one-sided effect: the other way does nothing
            continue
        assert (diff > 30).sum() > 20, f"{effect} {direction:+.0f} changed too few pixels"
        ys, xs = np.nonzero(diff > 30)
        nose_x = bundled_face().points[4, 0]
        if effect.endswith("_right"):  # the performer's right is the image's left
            assert xs.mean() < nose_x
        elif effect.endswith("_left"):
            assert xs.mean() > nose_x
        eyes_y = bundled_face().points[[33, 263], 1].mean()
        if effect.startswith(("brow", "lids", "gaze", "blink")):
            assert ys.max() < eyes_y + 20
        if effect.startswith(("jaw", "lip", "lower_lip", "upper_lip")):
            assert ys.min() > eyes_y + 20


def test_the_head_renders_what_its_actuators_do() -> None:
    sim = SimHead(load_head("simhead16"))
    rest = sim.render()
    sim.command(11, 2000)  # the jaw
    sim.step(50 * MS)
    early = sim.render()
    sim.step(2_000 * MS)
    late = sim.render()
    change = [np.abs(img.astype(int) - rest).sum() for img in (early, late)]
    assert 0 < change[0] < change[1]


def test_bad_photos(tmp_path: Path) -> None:
    face = bundled_face()
    image = tmp_path / "face.png"
    cv2.imwrite(str(image), face.image)
    good = {"points": face.points.tolist()}
    cases = {
        "garbage": "{not json",
        "no points": "{}",
        "short": json.dumps({"points": face.points[:10].tolist()}),
        "nan": json.dumps({"points": [[float("nan")] * 3] * 478}),
        "outside": json.dumps({"points": (face.points + 400).tolist()}),
        "not numbers": json.dumps({"points": [["a", "b", "c"]] * 478}),
    }
    for case, text in cases.items():
        path = tmp_path / f"{case}.json"
        path.write_text(text)
        with pytest.raises(PhotoError, match=str(path)):
            load_face(image, path)
    path = tmp_path / "good.json"
    path.write_text(json.dumps(good))
    assert load_face(image, path).points.shape == (478, 3)
    not_image = tmp_path / "x.jpg"
    not_image.write_text("nope")
    with pytest.raises(PhotoError, match="not an image"):
        load_face(not_image, path)
