"""Small learned profiles built by hand (no scikit-learn): a linear model per servo."""

from __future__ import annotations

import msgspec
import numpy as np

from facesynth.runtime.profiles import Learned, Profile, load_profile
from facesynth.runtime.profiles.learned import KNN, MLP, Layer, PolyRidge, Report, pack

INPUTS = ["brow_raise_inner_right", "jaw_open", "lip_corner_pull_left"]


def linear_learned(
    outputs: list[str],
    dead: list[str],
    coef: np.ndarray | None = None,
    *,
    low: float = -0.05,
    high: float = 0.1,
) -> Learned:
    """A degree-1 ridge: ``u = coef @ x`` on standardized inputs (mean 0, scale 0.1)."""
    n_in = len(INPUTS)
    if coef is None:
        coef = np.zeros((len(outputs), n_in))
        for i in range(len(outputs)):
            coef[i, i % n_in] = 1.0
    return Learned(
        inputs=list(INPUTS),
        reach_low=pack(np.full(n_in, low)),
        reach_high=pack(np.full(n_in, high)),
        input_mean=pack(np.zeros(n_in)),
        input_scale=pack(np.full(n_in, 0.1)),
        outputs=outputs,
        dead=dead,
        inverse=PolyRidge(
            degree=1,
            powers=pack(np.eye(n_in)),
            coef=pack(coef),
            intercept=pack(np.zeros(len(outputs))),
        ),
        forward=MLP(
            activation="relu",
            layers=[
                Layer(weights=pack(np.ones((len(outputs), 4))), bias=pack(np.zeros(4))),
                Layer(weights=pack(np.ones((4, n_in))), bias=pack(np.zeros(n_in))),
            ],
        ),
        report=Report(
            model="poly_ridge",
            servo_error={name: 0.02 for name in outputs},
            candidates={"poly_ridge": 0.02},
            samples=100,
            held_out=20,
        ),
    )


def knn_learned(outputs: list[str], dead: list[str]) -> Learned:
    """The linear mapping's data as a 3-nearest-neighbours model."""
    learned = linear_learned(outputs, dead)
    rng = np.random.default_rng(0)
    x = rng.normal(size=(30, len(INPUTS)))
    y = np.clip(x[:, [i % len(INPUTS) for i in range(len(outputs))]], -1, 1)
    model = KNN(k=3, weights="distance", train_x=pack(x), train_y=pack(y, "<f4"))
    return msgspec.structs.replace(learned, inverse=model)


def learned_profile(servos: int = 4, dead: int = 1, **kw: object) -> Profile:
    """head16_hardware cut to ``servos`` servos, the last ``dead`` of them dead."""
    hardware = load_profile("head16_hardware")
    specs = hardware.servos[:servos]
    names = [s.name for s in specs]
    learned = linear_learned(names[: servos - dead], names[servos - dead :], **kw)  # type: ignore[arg-type]
    return msgspec.structs.replace(hardware, servos=specs, learned=learned)
