"""Translator T with a learned profile, pure numpy: retarget the performer's face onto the
robot's, then run the inverse model (:mod:`facesynth.runtime.profiles.learned`).

Per frame, for each of the mapping's inputs ``i`` (a key of ``Features.raw``):

1. **Retarget.** A file fitted with retargeting options (``retarget``, file version 2) goes
   through :mod:`services.translator.retarget`: ``gain`` (0.9; 1.1 in new fits) of the
   performer's change, scaled into the robot's reach and clipped into it, features the robot
   cannot show held at its neutral, and
   each feature weighted in the plan by how much the performer moves it. A file without
   (version 1) is retargeted as follows.
   ``r`` is the performer's raw value (relative to the performer's neutral) and
   ``n`` its calibrated scale (``Features.named``: 0 neutral, ±1 the performer's extremes).
   The robot's face should move ``t = sign(r) · min(|r|, |n| · reach)``, ``reach`` being how
   far the robot moved that input on that side while babbling: the performer's own movement
   where the robot can follow it, scaled (a fraction of the performer's range becomes the same
   fraction of the robot's) only where the robot's range is smaller; then ``t`` is clipped into
   ``[reach_low, reach_high]``. An input without ``n`` is taken as ``r``, clipped; an input
   missing from the frame (or NaN) as 0, the robot's neutral; a frame with none of the inputs
   holds every servo (as a missing source does).
2. **Inverse model, then the self-model.** ``u = inverse((t - input_mean) / input_scale)``,
   each output servo's normalized command, clipped to its responsive range (``command_low``
   .. ``command_high``, [-1, 1] when the file has none: a learned profile never drives a
   servo into travel that moves nothing, so there is no slack to take up and less wear); with
   ``plan_steps``, that guess is refined through the forward model toward the reachable face
   nearest the target, within the same bounds (:mod:`facesynth.services.translator.self_model`);
   a servo a regional inverse gives from its region's features alone keeps the inverse's
   command, the others planned around it (the whole-face self-model would turn the neck to
   follow the gaze again). Open loop, with the file's ``retarget.lead_s``, each command is
   then led by its rate of change against the head's lag
   (:mod:`facesynth.services.translator.lead`), within the same bounds. A
   file's checks bound shapes and signs, not magnitudes: an output whose command is not finite
   (a model whose arithmetic overflows on extreme but finite parameters) holds its servo, as a
   missing source does.
3. **Smoothing.** Each output's ``u`` goes through a One Euro filter with the profile's
   (per-servo) smoothing parameters, in range units (the filters belong to the translator, so
   :meth:`~facesynth.services.translator.core.Translator.reset` and ``resume`` restart them).
4. **Position.** ``u`` → µs as :func:`services.translator.mapping.scaled_position` maps it (+1
   ``max_us``, -1 ``min_us``) but never reversed: the model learned the wiring. Dead servos
   stay at ``neutral_us``.

Motion limits, exclusive safety rules and clamping follow in the translator, as for written
profiles. Mirroring (``mirror``) swaps the performer's right and left before step 1.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from facesynth.runtime.profiles import Profile, Smoothing, has_source
from facesynth.runtime.profiles.learned import PolyRidge, command_range, unpack
from facesynth.runtime.profiles.learned_predict import (
    predictor,
    region_inputs,
    region_outputs,
)
from facesynth.services.translator.closed_loop import ClosedLoop, LoopOptions, LoopState
from facesynth.services.translator.filters import OneEuroFilter
from facesynth.services.translator.lead import PhaseLead
from facesynth.services.translator.retarget import Retargeter
from facesynth.services.translator.self_model import SelfModelPlanner


class LearnedTargets:
    """Target positions of a learned profile's servos, frame by frame."""

    def __init__(self, profile: Profile, filters: Mapping[str, OneEuroFilter | None]) -> None:
        """``filters``: a One Euro filter per output servo name (None: unfiltered)."""
        learned = profile.learned
        if learned is None:
            raise ValueError(f"profile {profile.name} is not a learned profile")
        self.inputs = list(learned.inputs)
        self.low, self.high = unpack(learned.reach_low), unpack(learned.reach_high)
        self.mean, self.scale = unpack(learned.input_mean), unpack(learned.input_scale)
        self.predict = predictor(learned.inverse)
        noise = None if learned.noise is None else unpack(learned.noise)
        self.retargeter = (
            None
            if learned.retarget is None
            else Retargeter(self.inputs, self.low, self.high, self.scale, noise, learned.retarget)
        )
        self.weights: np.ndarray | None = None
        self.u_low, self.u_high = command_range(learned)
        self.planner = (
            SelfModelPlanner(
                learned.forward,
                learned.plan_steps,
                learned.plan_prior,
                low=self.u_low,
                high=self.u_high,
            )
            if learned.plan_steps and isinstance(learned.forward, PolyRidge)
            else None
        )
        self.names = [spec.name for spec in profile.servos]
        self.outputs = list(learned.outputs)
        #: Outputs a regional inverse gives from their region's features alone: the plan
        #: through the whole-face self-model leaves them as the inverse gives them.
        self.regional = region_outputs(learned.inverse, len(self.inputs), len(self.outputs))
        #: The features each output's region reads (the closed loop corrects it on those).
        self.regions = region_inputs(learned.inverse, len(self.inputs), len(self.outputs))
        self.filters = [filters.get(name) for name in self.outputs]
        specs = [profile.servo(name) for name in self.outputs]
        self.neutral = np.array([s.neutral_us for s in specs])
        self.up = np.array([s.max_us - s.neutral_us for s in specs])
        self.down = np.array([s.neutral_us - s.min_us for s in specs])
        self.min_us = np.array([s.min_us for s in specs])
        self.max_us = np.array([s.max_us for s in specs])
        self.fixed = {name: profile.servo(name).neutral_us for name in learned.dead}
        #: The targets' row before a frame's outputs go in (dead servos at neutral), and
        #: where each output goes in it (a file names every servo once: outputs or dead).
        self.row = [self.fixed.get(name) for name in self.names]
        self.slots = [self.names.index(name) for name in self.outputs]
        self.forward = learned.forward
        #: The closed loop through the robot's camera (None: open loop; :meth:`close_loop`).
        self.closed: ClosedLoop | None = None
        #: The open loop's lead against the head's lag (None: not led; step 2 of the module).
        lead_s = 0.0 if learned.retarget is None else learned.retarget.lead_s
        self.lead = PhaseLead(lead_s) if lead_s > 0 else None

    def reset(self) -> None:
        """Forget the performance's motion (the lead's rate), as the filters are forgotten."""
        if self.lead is not None:
            self.lead.reset()

    def close_loop(
        self, options: LoopOptions | None = None, state: LoopState | None = None
    ) -> ClosedLoop:
        """Close the loop through the robot's observed face
        (:mod:`facesynth.services.translator.closed_loop`); ValueError without a
        ``poly_ridge`` self-model."""
        if not isinstance(self.forward, PolyRidge):
            raise ValueError("a closed loop needs a learned profile with a poly_ridge self-model")
        planner = self.planner or SelfModelPlanner(self.forward, 0, 0.0, self.u_low, self.u_high)
        self.closed = ClosedLoop(planner, self.u_low, self.u_high, options, state, self.regions)
        return self.closed

    def observed(self, raw: Mapping[str, float]) -> np.ndarray | None:
        """The robot's observed face (``Features.raw`` of its own camera) standardized as the
        models see it (NaN: missing), or None when it has none of the inputs."""
        values = np.array([raw.get(name, np.nan) for name in self.inputs], dtype=np.float64)
        if not np.isfinite(values).any():
            return None
        with np.errstate(all="ignore"):
            out: np.ndarray = (values - self.mean) / self.scale
        return out

    def sent(self, positions: Mapping[str, float], now_ns: int) -> None:
        """The translator's final ``positions`` went out at ``now_ns``: the closed loop pairs
        the robot's next observed faces with them (as normalized commands)."""
        if self.closed is None:
            return
        pulses = np.array([positions[name] for name in self.outputs], dtype=np.float64)
        offset = pulses - self.neutral
        with np.errstate(all="ignore"):  # a servo without travel on a side: 0 there
            u = np.where(offset >= 0, offset / self.up, offset / self.down)
        self.closed.sent(np.where(np.isfinite(u), u, 0.0), now_ns)

    def plan_weights(self) -> np.ndarray | None:
        """Each input's weight in the plan now (None: all 1)."""
        if self.weights is None and self.retargeter is not None:
            return self.retargeter.weights.weights()
        return self.weights

    def retarget(
        self, raw: Mapping[str, float], named: Mapping[str, float], t_ns: int | None = None
    ) -> np.ndarray | None:
        """The robot's input values ``t`` for a frame (None: none of the inputs is there).

        With the file's ``retarget`` options, :mod:`services.translator.retarget` gives them
        (and, when ``t_ns`` is given, updates each feature's weight in the plan, ``weights``);
        without, step 1 of the module's docstring does."""
        r = np.array([raw.get(name, np.nan) for name in self.inputs], dtype=np.float64)
        present = np.isfinite(r)
        if not present.any():
            return None
        if self.retargeter is not None:
            if t_ns is not None:
                self.weights = self.retargeter.weights.update(r, t_ns)
            return self.retargeter.targets(np.where(present, r, 0.0))
        r = np.where(present, r, 0.0)
        n = np.array([named.get(name, np.nan) for name in self.inputs], dtype=np.float64)
        reach = np.where(r >= 0, self.high, -self.low)
        with np.errstate(all="ignore"):  # inf * 0 reach (NaN), 1e300²: taken as unscaled below
            scaled = np.abs(n) * reach
        magnitude = np.where(np.isfinite(scaled), np.minimum(np.abs(r), scaled), np.abs(r))
        out: np.ndarray = np.clip(np.sign(r) * magnitude, self.low, self.high)
        return out

    def commands(self, t: np.ndarray) -> np.ndarray:
        """Each output's normalized command ``u`` for the robot's inputs ``t``, within its
        responsive range (``command_low`` .. ``command_high``, within [-1, 1]), or NaN where the
        models give no finite command (extreme parameters overflow)."""
        with np.errstate(all="ignore"):
            x = (t - self.mean) / self.scale
            out: np.ndarray = np.clip(self.predict(x[None, :])[0], self.u_low, self.u_high)
        out = np.where(np.isfinite(out), out, np.nan)
        if self.planner is not None and np.isfinite(x).all() and np.isfinite(out).all():
            out = self.planner.plan(x, out, self.plan_weights(), self.regional)
        return out

    def positions(self, u: np.ndarray) -> np.ndarray:
        """Pulses of the outputs for ``u`` (not reversed-aware), within their limits."""
        pulses = self.neutral + np.where(u >= 0, u * self.up, u * self.down)
        out: np.ndarray = np.minimum(np.maximum(pulses, self.min_us), self.max_us)  # np.clip's
        return out

    def targets(
        self,
        raw: Mapping[str, float],
        named: Mapping[str, float],
        t_ns: int | None,
        now_ns: int | None = None,
    ) -> list[float | None]:
        """Every servo's target in the profile's order (None: hold); filtered when ``t_ns``;
        corrected by the closed loop (when closed) at ``now_ns`` (its clock) when given."""
        t = self.retarget(raw, named, t_ns)
        if t is None:
            return [None] * len(self.names)
        u = self.commands(t)
        if self.closed is not None and now_ns is not None and np.isfinite(u).all():
            with np.errstate(all="ignore"):
                x = (t - self.mean) / self.scale
            u = self.closed.correct(u, x, self.plan_weights(), now_ns)
        elif self.lead is not None and t_ns is not None and np.isfinite(u).all():
            u = np.minimum(np.maximum(self.lead(u, t_ns), self.u_low), self.u_high)
        finite = np.isfinite(u)
        oks = finite.tolist()
        if t_ns is not None:  # a servo held (no finite command) leaves its filter as it was
            u = np.array(
                [
                    v if f is None or not ok else f(v, t_ns)
                    for f, v, ok in zip(self.filters, u.tolist(), oks, strict=True)
                ]
            )
        pulses = self.positions(np.where(finite, u, 0.0)).tolist()
        row = list(self.row)
        for slot, pulse, ok in zip(self.slots, pulses, oks, strict=True):
            row[slot] = pulse if ok else None
        return row


def learned_targets(
    profile: Profile,
    filters: dict[tuple[object, ...], OneEuroFilter | None],
    make_filter: Callable[[Smoothing | None], OneEuroFilter | None],
) -> LearnedTargets | None:
    """The learned targets of ``profile`` (None when it is not learned); each output's One
    Euro filter is added to the translator's ``filters`` (key ``("learned", name)``)."""
    if profile.learned is None:
        return None
    own = {}
    for name in profile.learned.outputs:
        own[name] = filters[("learned", name)] = make_filter(
            profile.smoothing_for(profile.servo(name))
        )
    return LearnedTargets(profile, own)


def unsourced(profile: Profile) -> str | None:
    """Why T cannot drive ``profile``: servos without a source (a hardware profile) in a
    profile that is not learned (None: it can)."""
    missing = [spec.name for spec in profile.servos if not has_source(spec)]
    if profile.learned is not None or not missing:
        return None
    shown = ", ".join(missing[:3]) + (", …" if len(missing) > 3 else "")
    return (
        f"profile {profile.name} has servos without a source ({shown}): a hardware profile "
        "drives nothing until it is learned (facesynth learn writes NAME.learned)"
    )
