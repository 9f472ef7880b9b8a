"""The simulated head's pure core: actuator dynamics and responses, time as data.

:class:`SimHead` holds one actuator per channel of its :class:`~.config.HeadConfig`:

* :meth:`SimHead.command` sets a channel's pulse (µs; 0 = pulses off: the actuator goes limp
  and stays where it is), clamped to the range the actuator physically responds over;
* :meth:`SimHead.step` advances every actuator to the time ``t_ns``: the horn turns toward the
  pulse at most ``slew_us_per_s``, the skin follows the horn with a first-order lag
  (``lag_s``);
* the skin's position becomes the actuator's output (:func:`response`: dead band around the
  rest pulse, a curve over each side's travel, a gain per side, reversed or not), and the
  outputs drive the effects (``effects`` linearly, ``coupling`` by output·|output|);
* :meth:`SimHead.render` draws the face under those activations (:mod:`.renderer`).

Time never comes from a clock here: the shell (:mod:`.server`) or a test passes it in.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .config import Actuator, HeadConfig
from .renderer import Renderer, default_renderer

__all__ = ["CHANNELS", "SimHead", "response"]

#: Channels a head can be commanded on (a 24-channel Maestro's).
CHANNELS = 24


def response(actuator: Actuator, position_us: float) -> float:
    """The actuator's signed output (0 at rest; ±gain at the ends) with the skin at
    ``position_us`` (see the module doc)."""
    offset = position_us - actuator.rest_us
    magnitude = abs(offset) - actuator.dead_band_us
    if magnitude <= 0:
        return 0.0
    up = offset > 0
    travel = (actuator.max_us if up else -actuator.min_us) - actuator.dead_band_us
    travel += -actuator.rest_us if up else actuator.rest_us
    share = min(magnitude / travel, 1.0)
    if actuator.curve == "power":
        share = share**actuator.exponent
    elif actuator.curve == "smoothstep":
        share = share * share * (3.0 - 2.0 * share)
    out = share * (actuator.gain_up if up else -actuator.gain_down)
    return -out if actuator.reversed else out


@dataclass
class _State:
    pulse_us: float  # the commanded pulse (0 = off)
    horn_us: float  # where the horn is (slew-limited)
    skin_us: float  # where the skin is (lagging the horn)


class SimHead:
    """A simulated head (see the module doc). ``t_ns`` is the time of its rest state."""

    def __init__(self, config: HeadConfig, renderer: Renderer | None = None, t_ns: int = 0):
        self.config = config
        self._actuators = config.by_channel()
        self._renderer = renderer
        self._t_ns = t_ns
        self._pulses: dict[int, float] = {}
        self._states = {ch: _State(0.0, a.rest_us, a.rest_us) for ch, a in self._actuators.items()}

    @property
    def t_ns(self) -> int:
        """The time the head has been stepped to."""
        return self._t_ns

    def command(self, channel: int, pulse_us: float) -> None:
        """Pulse ``pulse_us`` on ``channel`` from now on (0 = off). A channel without an
        actuator keeps its pulse (see :meth:`pulses`) and moves nothing."""
        if not 0 <= channel < CHANNELS:
            raise ValueError(f"channel {channel} is not within 0..{CHANNELS - 1}")
        if not math.isfinite(pulse_us) or pulse_us < 0:
            raise ValueError(f"pulse {pulse_us} µs on channel {channel} is not a pulse")
        self._pulses[channel] = float(pulse_us)
        state = self._states.get(channel)
        if state is not None:
            actuator = self._actuators[channel]
            clamped = min(max(pulse_us, actuator.min_us), actuator.max_us)
            state.pulse_us = clamped if pulse_us > 0 else 0.0

    def step(self, t_ns: int) -> None:
        """Advance every actuator to ``t_ns`` (not before the last step)."""
        dt = (t_ns - self._t_ns) / 1e9
        if dt < 0:
            raise ValueError(f"time went back: {t_ns} ns after {self._t_ns} ns")
        self._t_ns = t_ns
        if dt == 0:
            return
        for channel, state in self._states.items():
            actuator = self._actuators[channel]
            if state.pulse_us > 0:
                reach = actuator.slew_us_per_s * dt
                gap = state.pulse_us - state.horn_us
                state.horn_us += max(-reach, min(reach, gap))
            if actuator.lag_s > 0:
                state.skin_us += (state.horn_us - state.skin_us) * (
                    1.0 - math.exp(-dt / actuator.lag_s)
                )
            else:
                state.skin_us = state.horn_us

    def pulses(self) -> dict[int, float]:
        """The pulse commanded on every channel that has been commanded (µs, 0 = off)."""
        return dict(self._pulses)

    def positions(self) -> dict[int, float]:
        """Where each actuator's skin is, as a pulse (µs), by channel."""
        return {ch: state.skin_us for ch, state in self._states.items()}

    def outputs(self) -> dict[int, float]:
        """Each actuator's signed output (:func:`response` of its skin), by channel."""
        return {ch: response(self._actuators[ch], s.skin_us) for ch, s in self._states.items()}

    def moving(self, tolerance_us: float = 0.5) -> bool:
        """Whether some skin is still more than ``tolerance_us`` from its pulse."""
        return any(
            s.pulse_us > 0 and abs(s.pulse_us - s.skin_us) > tolerance_us
            for s in self._states.values()
        )

    def activations(self) -> dict[str, float]:
        """Every effect's activation now (effects no actuator drives are left out)."""
        out: dict[str, float] = {}
        for channel, value in self.outputs().items():
            actuator = self._actuators[channel]
            for effect, amount in actuator.effects.items():
                out[effect] = out.get(effect, 0.0) + amount * value
            for effect, amount in actuator.coupling.items():
                out[effect] = out.get(effect, 0.0) + amount * value * abs(value)
        return out

    def render(self) -> np.ndarray:
        """The head's camera image now (BGR, 320x320 for the bundled photo)."""
        if self._renderer is None:
            self._renderer = default_renderer()
        return self._renderer.render(self.activations())
