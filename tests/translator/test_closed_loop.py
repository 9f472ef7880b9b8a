"""The closed loop's pure core: a head whose real face differs from the self-model, observed
frame by frame in virtual time (no camera: the head's face is computed)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from facesynth.runtime.profiles.learned import PolyRidge, pack
from facesynth.services.translator.closed_loop import (
    MAX_ERROR,
    ClosedLoop,
    LoopOptions,
    LoopState,
)
from facesynth.services.translator.lead import PhaseLead
from facesynth.services.translator.self_model import SelfModelPlanner

FRAME_NS = 33_333_333
N_SERVOS, N_FEATURES = 3, 4


def forward_model(seed: int = 0) -> PolyRidge:
    """A degree-2 self-model of ``N_SERVOS`` commands → ``N_FEATURES`` standardized features."""
    rng = np.random.default_rng(seed)
    powers = [
        p for p in itertools.product(range(3), repeat=N_SERVOS) if 0 < sum(p) <= 2
    ]  # every term of degree 1 or 2
    coef = rng.normal(0.0, 0.15, (N_FEATURES, len(powers)))
    linear = [i for i, p in enumerate(powers) if sum(p) == 1]
    coef[:, linear] += rng.normal(0.0, 1.0, (N_FEATURES, N_SERVOS))
    return PolyRidge(
        degree=2,
        powers=pack(np.array(powers, dtype=np.float64)),
        coef=pack(coef),
        intercept=pack(np.zeros(N_FEATURES)),
    )


def planner(low: float = -1.0, high: float = 1.0) -> SelfModelPlanner:
    return SelfModelPlanner(
        forward_model(), 0, 0.0, np.full(N_SERVOS, low), np.full(N_SERVOS, high)
    )


class Head:
    """The real face: the self-model's, off by a bias and other slopes (affine in the
    commands: what the loop's refinement models)."""

    def __init__(self, model: SelfModelPlanner) -> None:
        self.model = model
        self.bias = np.array([0.4, -0.3, 0.2, 0.0])
        self.slope = np.array([[-0.3, 0.1, 0.0], [0.0, -0.2, 0.0], [0.1, 0.0, -0.3], [0, 0, 0]])

    def face(self, u: np.ndarray) -> np.ndarray:
        predicted, _ = self.model.face(u)
        out: np.ndarray = predicted + self.bias + self.slope @ u
        return out


class WornHead(Head):
    """The real face: the self-model's, but with actuators weaker and their horns moved on
    their shafts since babbling (every face the self-model can make is still reachable)."""

    gain = np.array([0.7, 1.0, 0.8])
    offset = np.array([0.1, -0.1, 0.05])

    def face(self, u: np.ndarray) -> np.ndarray:
        out, _ = self.model.face(self.gain * u + self.offset)
        return out


def run(
    loop: ClosedLoop | None,
    head: Head,
    targets: list[np.ndarray],
    u0: np.ndarray,
    *,
    see: bool = True,
) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Commands and faces per frame: each frame's command is corrected from the faces seen so
    far, sent, and the head's face for it is seen at the same instant."""
    commands, faces = [], []
    for index, x in enumerate(targets):
        t_ns = index * FRAME_NS
        u = u0 if loop is None else loop.correct(u0, x, None, t_ns)
        face = head.face(u)
        if loop is not None:
            loop.sent(u, t_ns)
            loop.observe(face if see else None, t_ns)
        commands.append(u)
        faces.append(face)
    return commands, faces


def test_the_loop_brings_the_real_face_to_a_target_the_open_loop_misses() -> None:
    model = planner()
    head = WornHead(model)
    u_target = np.array([0.3, -0.2, 0.4])
    x, _ = model.face(u_target)  # the self-model would make it with u_target
    # every servo moves every feature here: corrected over the whole face (test_loop_regions)
    options = LoopOptions(damping=0.05, region_share=0.0)
    loop = ClosedLoop(model, model.low, model.high, options)
    _, faces_open = run(None, head, [x] * 120, u_target)
    _, faces = run(loop, head, [x] * 120, u_target)
    open_error = np.linalg.norm(faces_open[-1] - x)
    closed_error = np.linalg.norm(faces[-1] - x)
    assert open_error > 0.15
    assert closed_error < 0.1 * open_error


def test_the_self_model_is_refined_from_the_live_pairs() -> None:
    model = planner()
    head = Head(model)
    rng = np.random.default_rng(3)
    loop = ClosedLoop(
        model, model.low, model.high, LoopOptions(forgetting=0.99, slope_prior=1.0, response_s=0.0)
    )
    for index in range(300):  # commands that move (a performance), each face seen after it
        u = rng.uniform(-0.8, 0.8, N_SERVOS)
        loop.sent(u, index * FRAME_NS)
        loop.observe(head.face(u), index * FRAME_NS)
    assert loop.state.updates == 300
    for u in rng.uniform(-0.8, 0.8, (20, N_SERVOS)):
        refined, _ = loop.model(u)
        assert np.allclose(refined, head.face(u), atol=1e-3)


def test_each_frame_moves_the_correction_by_at_most_the_bounded_step() -> None:
    model = planner()
    head = Head(model)
    x, _ = model.face(np.array([0.5, 0.5, -0.5]))
    options = LoopOptions(max_step=0.02, damping=0.05)
    loop = ClosedLoop(model, model.low, model.high, options)
    commands, _ = run(loop, head, [x] * 60, np.zeros(N_SERVOS))
    steps = np.abs(np.diff(np.array([np.zeros(N_SERVOS), *commands]), axis=0))
    assert steps.max() <= 0.02 + 1e-12
    assert steps.max() > 0.019  # it did move, at the bound
    assert np.abs(loop.correction).max() <= options.max_correction


def test_commands_stay_within_the_responsive_range() -> None:
    model = planner(-0.4, 0.3)
    head = Head(model)
    far = np.full(N_FEATURES, 50.0)  # a target far beyond anything the head makes
    loop = ClosedLoop(model, model.low, model.high, LoopOptions(max_step=0.5))
    commands, _ = run(loop, head, [far, -far] * 30, np.array([0.3, -0.4, 0.0]))
    stacked = np.array(commands)
    assert stacked.min() >= -0.4 and stacked.max() <= 0.3
    assert np.isclose(stacked.min(), -0.4) or np.isclose(stacked.max(), 0.3)


def test_a_lost_face_returns_smoothly_to_the_open_loop() -> None:
    model = planner()
    head = WornHead(model)
    u0 = np.array([0.3, -0.2, 0.4])
    x, _ = model.face(u0)
    options = LoopOptions(max_step=0.05, damping=0.05)
    loop = ClosedLoop(model, model.low, model.high, options)
    run(loop, head, [x] * 60, u0)
    corrected = loop.correct(u0, x, None, 60 * FRAME_NS)
    assert np.abs(corrected - u0).max() > 0.08
    # The face is lost (None): each frame returns by at most max_step, then u0 exactly.
    loop.observe(None, 61 * FRAME_NS)
    previous = corrected
    for index in range(62, 100):
        u = loop.correct(u0, x, None, index * FRAME_NS)
        assert np.abs(u - previous).max() <= 0.05 + 1e-12
        previous = u
    assert np.array_equal(previous, np.clip(u0, model.low, model.high))


def test_a_face_older_than_the_bound_counts_as_lost() -> None:
    model = planner()
    head = Head(model)
    u0 = np.array([0.3, -0.2, 0.4])
    x, _ = model.face(u0)
    loop = ClosedLoop(model, model.low, model.high, LoopOptions(max_age_s=0.2, max_step=2.0))
    run(loop, head, [x] * 30, u0)
    last_ns = 29 * FRAME_NS
    assert not loop.lost(last_ns + 199_000_000)
    assert loop.lost(last_ns + 201_000_000)
    assert np.array_equal(loop.correct(u0, x, None, last_ns + 201_000_000), u0)
    assert loop.lost(last_ns - 201_000_000)  # a face from another clock's future: not used


def test_without_any_face_it_is_the_open_loop() -> None:
    model = planner()
    loop = ClosedLoop(model, model.low, model.high)
    u0 = np.array([0.1, 0.2, -0.3])
    x = np.ones(N_FEATURES)
    assert np.array_equal(loop.correct(u0, x, None, 0), u0)
    loop.observe(np.ones(N_FEATURES), 0)  # no command sent yet: nothing to pair it with
    assert loop.lost(0) and loop.state.updates == 0


def test_missing_and_wild_features_do_not_derail_the_fit() -> None:
    model = planner()
    head = Head(model)
    loop = ClosedLoop(model, model.low, model.high)
    u = np.array([0.2, 0.1, -0.1])
    loop.sent(u, 0)
    face = head.face(u)
    face[1] = np.nan  # the tracker had no value for it
    face[2] = 1e9  # a tracking glitch
    before = loop.state.weights.copy()
    loop.observe(face, 0)
    assert np.array_equal(loop.state.weights[1], before[1])
    assert np.isfinite(loop.state.weights).all()
    assert np.abs(loop.state.weights[2] - before[2]).max() <= MAX_ERROR
    assert np.isfinite(loop.correct(u, np.zeros(N_FEATURES), None, 0)).all()


def test_the_covariance_stays_bounded_without_excitation() -> None:
    model = planner()
    head = Head(model)
    options = LoopOptions(forgetting=0.9, prior=1.0, slope_prior=0.1)
    loop = ClosedLoop(model, model.low, model.high, options)
    u = np.array([0.2, 0.1, -0.1])
    for index in range(2000):  # one pose held: most directions never excited
        loop.sent(u, index * FRAME_NS)
        loop.observe(head.face(u), index * FRAME_NS)
    diagonal = np.diag(loop.state.covariance)
    assert diagonal[0] <= 1.0 + 1e-9 and diagonal[1:].max() <= 0.1 + 1e-9
    assert np.isfinite(loop.state.weights).all()


def test_a_face_is_paired_with_the_commands_then_in_effect() -> None:
    model = planner()
    loop = ClosedLoop(model, model.low, model.high, LoopOptions(response_s=0.0))
    first, second = np.zeros(N_SERVOS), np.ones(N_SERVOS) * 0.5
    loop.sent(first, 0)
    loop.sent(second, 100)
    assert loop.commands_at(-1) is None
    assert np.array_equal(loop.commands_at(99), first)
    assert np.array_equal(loop.commands_at(100), second)
    lagging = ClosedLoop(model, model.low, model.high, LoopOptions(response_s=0.1))
    lagging.sent(first, 0)
    lagging.sent(second, 1_000_000_000)
    at = lagging.commands_at(1_100_000_000)  # one time constant after the change
    assert at is not None
    assert np.allclose(at, second * (1 - np.exp(-1.0)))
    lagging.sent(first, 0)  # the clock went back: the history restarts from there
    assert np.array_equal(lagging.commands_at(50), first)


def test_a_state_that_overflows_starts_the_fit_afresh() -> None:
    model = planner()
    state = LoopState.fresh(N_FEATURES, N_SERVOS, LoopOptions())
    state.covariance[:] = 1e308  # finite, but its next step is not
    loop = ClosedLoop(model, model.low, model.high, state=state)
    u = np.array([0.9, 0.9, 0.9])
    loop.sent(u, 0)
    loop.observe(np.full(N_FEATURES, 2.0), 0)
    assert loop.state.updates == 0 and not loop.state.weights.any()
    assert np.array_equal(loop.state.covariance, np.diag([1.0, 0.1, 0.1, 0.1]))


def test_reset_forgets_the_frames_not_the_learning() -> None:
    model = planner()
    head = Head(model)
    u0 = np.array([0.3, -0.2, 0.4])
    x, _ = model.face(u0)
    loop = ClosedLoop(model, model.low, model.high)
    run(loop, head, [x] * 20, u0)
    weights = loop.state.weights.copy()
    loop.reset()
    assert loop.lost(20 * FRAME_NS) and not loop.correction.any()
    assert loop.commands_at(20 * FRAME_NS) is None
    assert np.array_equal(loop.state.weights, weights)


@pytest.mark.parametrize(
    ("field", "value"),
    [("max_step", 0.0), ("forgetting", 1.5), ("damping", float("nan")), ("max_age_s", -1.0)],
)
def test_bad_options_are_refused_in_one_line(field: str, value: float) -> None:
    model = planner()
    with pytest.raises(ValueError, match=f"closed loop: {field} ") as info:
        ClosedLoop(model, model.low, model.high, LoopOptions(**{field: value}))
    assert "\n" not in str(info.value)


def test_a_state_of_other_models_is_refused() -> None:
    model = planner()
    state = LoopState.fresh(N_FEATURES + 1, N_SERVOS, LoopOptions())
    with pytest.raises(ValueError, match="does not fit 4 features and 3 servos"):
        ClosedLoop(model, model.low, model.high, state=state)


def test_the_lead_moves_a_ramp_earlier_by_lead_s() -> None:
    """Commands planned along a ramp go out ``lead_s`` × their rate ahead (the face follows
    them late); a held target has no lead; a lost face, none either."""
    model = planner()
    head = Head(model)
    options = LoopOptions(lead_s=0.1, damping=1e6, max_step=2.0, max_correction=2.0)
    rate = 0.3  # normalized units a second
    ramp = [np.full(N_SERVOS, -0.5 + rate * i * FRAME_NS / 1e9) for i in range(20)]
    x = np.zeros(N_FEATURES)
    loop = ClosedLoop(model, model.low, model.high, options)
    for index, u0 in enumerate(ramp):
        t_ns = index * FRAME_NS
        u = loop.correct(u0, x, None, t_ns)
        loop.sent(u, t_ns)
        loop.observe(head.face(u), t_ns)
    assert np.allclose(u - ramp[-1], 0.1 * rate, atol=1e-3)
    for index in range(20, 40):  # held
        u = loop.correct(ramp[-1], x, None, index * FRAME_NS)
        loop.observe(head.face(u), index * FRAME_NS)
    assert np.allclose(u, ramp[-1], atol=1e-6)
    blind = ClosedLoop(model, model.low, model.high, options)  # never sees a face
    for index, u0 in enumerate(ramp):
        assert np.array_equal(blind.correct(u0, x, None, index * FRAME_NS), u0)


def test_the_lead_is_the_open_loops_phase_lead_restarted_when_the_face_is_lost() -> None:
    """One lead for open and closed loop: the planned commands are led as
    :class:`PhaseLead` leads the open loop's (the rate low-passed: a jump in the plan is not
    led by its whole frame-to-frame rate); a lost face restarts it (no stale rate)."""
    model = planner()
    head = Head(model)
    options = LoopOptions(lead_s=0.1, damping=1e6, max_step=2.0, max_correction=2.0)
    loop = ClosedLoop(model, model.low, model.high, options)
    lead = PhaseLead(0.1)
    x = np.zeros(N_FEATURES)
    plan = [np.full(N_SERVOS, v) for v in (0.0, 0.0, 0.3, 0.3, 0.1, 0.1)]
    for index, u0 in enumerate(plan):
        t_ns = index * FRAME_NS
        expected = u0  # the first frame has seen no face: the open loop, nothing led
        if index > 0:
            expected = np.clip(lead(u0 + loop.wanted(u0, x, None), t_ns), model.low, model.high)
        u = loop.correct(u0, x, None, t_ns)
        assert np.allclose(u, expected, atol=1e-12), index
        loop.sent(u, t_ns)
        loop.observe(head.face(u), t_ns)
        if index == 2:  # the jump: led by less than its raw rate (0.9 a frame here)
            assert 0.5 < u[0] - u0[0] < 0.65
    later = len(plan) * FRAME_NS + round(options.max_age_s * 1e9) + 1  # the face is lost
    assert np.array_equal(loop.correct(plan[-1], x, None, later), plan[-1])
    loop.observe(head.face(plan[-1]), later)
    moved = plan[-1] + 0.2  # the first frame after: no rate from before the loss
    assert np.allclose(loop.correct(moved, x, None, later + FRAME_NS), moved, atol=1e-3)
