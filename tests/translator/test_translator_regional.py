"""T with a regional inverse model (file version 3): a servo given from its region's features
alone keeps that command, and the plan through the whole-face self-model refines the others
only (services/translator/learned.py)."""

from __future__ import annotations

import msgspec
import numpy as np
from test_translator_learned import ZERO, learned_profile

from facesynth.runtime.profiles import Profile, encode_learned_profile, parse_learned_profile
from facesynth.runtime.profiles.learned import Part, PolyRidge, Regional, pack
from facesynth.runtime.profiles.learned_predict import region_inputs, region_outputs
from facesynth.services.translator.closed_loop import LoopOptions
from facesynth.services.translator.core import Translator

#: The self-model: servo i moves input i (the second one only half its reach), and the first
#: servo (the "neck") moves input 1 as much as the second does.
FORWARD = PolyRidge(
    degree=1,
    powers=pack(np.eye(3)),
    coef=pack(np.array([[1.0, 0.0, 0.0], [0.5, 0.5, 0.0], [0.0, 0.0, 1.0]])),
    intercept=pack(np.zeros(3)),
)


def _planning(regional: bool) -> Profile:
    """Three live servos following their inputs (u = t / 0.1), planned through FORWARD; with
    ``regional``, the first one from input 0 alone, the others from the whole face."""
    profile = learned_profile(servos=3, dead=0)
    learned = profile.learned
    assert learned is not None and isinstance(learned.inverse, PolyRidge)
    inverse: PolyRidge | Regional = learned.inverse
    if regional:
        first = PolyRidge(
            degree=1, powers=pack(np.eye(1)), coef=pack(np.eye(1)), intercept=pack(np.zeros(1))
        )
        rest = PolyRidge(
            degree=1,
            powers=pack(np.eye(3)),
            coef=pack(np.eye(3)[1:]),
            intercept=pack(np.zeros(2)),
        )
        inverse = Regional(
            parts=[
                Part(inputs=[0], outputs=[0], model=first),
                Part(inputs=[0, 1, 2], outputs=[1, 2], model=rest),
            ]
        )
    mapping = msgspec.structs.replace(
        learned, inverse=inverse, forward=FORWARD, plan_steps=6, plan_prior=0.02
    )
    # through the file: what T runs is what the loader accepts
    return parse_learned_profile(
        encode_learned_profile(msgspec.structs.replace(profile, learned=mapping))
    )


def test_the_plan_leaves_a_servo_its_region_gives_and_refines_the_others() -> None:
    regional, whole = _planning(regional=True), _planning(regional=False)
    assert regional.learned is not None and whole.learned is not None
    assert region_outputs(regional.learned.inverse, 3, 3).tolist() == [True, False, False]
    assert not region_outputs(whole.learned.inverse, 3, 3).any()
    raw = {"jaw_open": 0.1}  # the performer opens her jaw wide; input 0 stays at neutral
    neck = regional.servos[0]
    planned = Translator(whole).positions(ZERO, named={}, raw=raw)
    kept = Translator(regional).positions(ZERO, named={}, raw=raw)
    # the second servo alone cannot open the jaw that far: the whole-face plan moves the
    # first servo to help (trading input 0 for input 1) …
    assert abs(planned[neck.name] - neck.neutral_us) > 5.0
    # … the regional one leaves it where its own region puts it: at neutral
    assert kept[neck.name] == neck.neutral_us
    # the second servo is planned in both
    second = regional.servos[1]
    assert kept[second.name] > second.neutral_us + 5.0
    assert planned[second.name] > second.neutral_us + 5.0


def test_the_closed_loop_corrects_each_servo_through_its_region() -> None:
    """The regions reach T's closed loop from the file: the first servo is corrected on
    input 0 alone, the others on the whole face; a whole-face inverse has one region."""
    regional, whole = _planning(regional=True), _planning(regional=False)
    assert regional.learned is not None
    masks = region_inputs(regional.learned.inverse, 3, 3)
    assert masks.tolist() == [[True, False, False], [True, True, True], [True, True, True]]
    on = LoopOptions(regional=True)
    groups = Translator(regional).close_loop(on).groups
    assert groups is not None
    assert groups[0][groups[1][0]].tolist() == [1.0, 0.0, 0.0]
    assert Translator(whole).close_loop(on).groups is None
    assert Translator(regional).close_loop().groups is None  # off by default
