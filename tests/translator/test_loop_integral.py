"""The closed loop's integral action: each face compared with the target of the frame that
made it (a head whose face is seen late), bounded and wound down (services/translator/
loop_integral.py through ClosedLoop)."""

from __future__ import annotations

from collections import deque

import numpy as np
from test_closed_loop import FRAME_NS, N_FEATURES, N_SERVOS, WornHead, planner

from facesynth.services.translator.closed_loop import ClosedLoop, LoopOptions
from facesynth.services.translator.loop_integral import IntegralAction

#: The head's face is seen this many frames after the command that made it.
LATE = 3


def run_late(
    loop: ClosedLoop, head: WornHead, targets: list[np.ndarray], u0: np.ndarray
) -> list[np.ndarray]:
    """Each frame's command is corrected and sent; the camera's face of that instant is the
    head's face for the command sent ``LATE`` frames earlier (actuators, skin, camera)."""
    sent: deque[np.ndarray] = deque([u0] * LATE, maxlen=LATE)
    faces = []
    for index, x in enumerate(targets):
        t_ns = index * FRAME_NS
        u = loop.correct(u0, x, None, t_ns)
        loop.sent(u, t_ns)
        face = head.face(sent[0])
        sent.append(u)
        loop.observe(face, t_ns)
        faces.append(face)
    return faces


def late_options(**changes: float) -> LoopOptions:
    # the model-based correction kept small (strong damping, a fit that hardly forgets and
    # barely moves the slopes), so what closes the gap is the integral
    base = dict(
        damping=50.0,
        response_s=0.0,
        forgetting=1.0,
        prior=1e-6,
        slope_prior=1e-6,
        delay_s=LATE * FRAME_NS / 1e9,
        integral_leak=1.0,
    )
    return LoopOptions(**{**base, **changes})


def test_integral_action_closes_the_gap_the_model_based_correction_leaves() -> None:
    model = planner()
    u_target = np.array([0.3, -0.2, 0.4])
    x, _ = model.face(u_target)
    without = ClosedLoop(model, model.low, model.high, late_options(integral_gain=0.0))
    with_integral = ClosedLoop(model, model.low, model.high, late_options(integral_gain=0.3))
    open_error = np.linalg.norm(run_late(without, WornHead(model), [x] * 200, u_target)[-1] - x)
    closed = run_late(with_integral, WornHead(model), [x] * 200, u_target)
    assert open_error > 0.15
    assert np.linalg.norm(closed[-1] - x) < 0.2 * open_error
    assert with_integral.integral.updates > 150


def test_a_face_is_compared_with_the_target_of_the_frame_that_made_it() -> None:
    action = IntegralAction(N_SERVOS, gain=0.5, leak=1.0, delay_s=0.1, bound=1.0, max_error=3.0)
    for index in range(10):
        action.planned(np.full(N_FEATURES, float(index)), None, index * 50_000_000)
    paired = action.target_at(9 * 50_000_000)  # made by the frame sent 0.1 s earlier: 7
    assert paired is not None and np.array_equal(paired[0], np.full(N_FEATURES, 7.0))
    assert action.target_at(50_000_000) is None  # nothing was sent 0.1 s before it
    action.planned(np.zeros(N_FEATURES), None, 0)  # the clock went back: pairs afresh
    assert action.target_at(9 * 50_000_000) is not None
    assert action.target_at(200_000_000) is not None and len(action.targets) == 1


def test_the_integral_is_bounded_and_does_not_wind_up_at_an_end() -> None:
    model = planner(-0.4, 0.3)
    far = np.full(N_FEATURES, 50.0)  # beyond anything the head makes
    options = late_options(integral_gain=1.0, max_correction=0.5, max_step=2.0)
    loop = ClosedLoop(model, model.low, model.high, options)
    run_late(loop, WornHead(model), [far] * 100, np.zeros(N_SERVOS))
    assert np.abs(loop.integral.z).max() <= 0.5 + 1e-12
    # a servo at an end of its range integrates no further toward it
    action = IntegralAction(N_SERVOS, gain=1.0, leak=1.0, delay_s=0.0, bound=1.0, max_error=3.0)
    action.planned(far, None, 0)
    _, jacobian = model.face(np.zeros(N_SERVOS))
    at_end = np.array([0.3, 0.0, -0.4])
    action.update(np.zeros(N_FEATURES), 0, jacobian, 1e-3, at_end, model.low, model.high)
    unbounded = IntegralAction(N_SERVOS, gain=1.0, leak=1.0, delay_s=0.0, bound=1.0, max_error=3.0)
    unbounded.planned(far, None, 0)
    inside = np.zeros(N_SERVOS)
    unbounded.update(np.zeros(N_FEATURES), 0, jacobian, 1e-3, inside, model.low, model.high)
    pushed = unbounded.z
    assert pushed[0] > 0 or pushed[2] < 0  # free, it pushes a servo toward its end
    if pushed[0] > 0:
        assert action.z[0] == 0.0
    if pushed[2] < 0:
        assert action.z[2] == 0.0
    assert action.z[1] == pushed[1]


def test_the_leak_lets_go_of_an_unreachable_target() -> None:
    model = planner()
    far = np.full(N_FEATURES, 50.0)
    u0 = np.array([0.3, -0.2, 0.4])
    x, _ = model.face(u0)
    options = late_options(integral_gain=0.2, integral_leak=0.8, max_correction=0.6)
    loop = ClosedLoop(model, model.low, model.high, options)
    run_late(loop, WornHead(model), [far] * 60, u0)
    held = np.abs(loop.integral.z).max()
    run_late(loop, WornHead(model), [x] * 60, u0)  # the performance asks for less again
    assert np.abs(loop.integral.z).max() < 0.5 * held


def test_a_lost_face_drops_the_integral_and_returns_smoothly() -> None:
    model = planner()
    u0 = np.array([0.3, -0.2, 0.4])
    x, _ = model.face(u0)
    options = late_options(integral_gain=0.3, max_step=0.05)
    loop = ClosedLoop(model, model.low, model.high, options)
    run_late(loop, WornHead(model), [x] * 100, u0)
    assert np.abs(loop.integral.z).max() > 0.05
    before = loop.correct(u0, x, None, 100 * FRAME_NS)
    loop.observe(None, 101 * FRAME_NS)
    assert not loop.integral.z.any()
    previous = before
    for index in range(102, 140):
        u = loop.correct(u0, x, None, index * FRAME_NS)
        assert np.abs(u - previous).max() <= 0.05 + 1e-12
        previous = u
    assert np.array_equal(previous, np.clip(u0, model.low, model.high))


def test_off_by_default_it_keeps_no_targets() -> None:
    model = planner()
    loop = ClosedLoop(model, model.low, model.high, LoopOptions(integral_gain=0.0))
    run_late(loop, WornHead(model), [np.zeros(N_FEATURES)] * 10, np.zeros(N_SERVOS))
    assert not loop.integral.targets and loop.integral.updates == 0
