"""A profile's servos on a board's channels, in the board's units: the drivers' last safety check.

Positions reach a driver already clamped by the control core; a board driver still never sends
a value outside the servo's limits. Limits are rounded *inward* to the board's resolution (a
1000.3 µs minimum becomes 1001 µs on a 1 µs board, 1000.5 on a quarter-µs board), and every
position is rounded to that resolution and clamped again right before it is encoded.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from facesynth.runtime.profiles import Profile
from facesynth.services.control.drivers.base import DriverConfigError, DriverError


@dataclass(frozen=True)
class ChannelLimits:
    """One channel's limits in board units (integers: µs / step)."""

    name: str
    low: int
    neutral: int
    high: int

    def clamp(self, units: int) -> int:
        """``units`` held inside ``[low, high]``."""
        return min(max(units, self.low), self.high)


class ServoMap:
    """Where each servo of ``profile`` is wired and how far it may go, in units of ``step_us``.

    ``board`` names the controller in messages; ``range_us`` is what it can drive at all and
    ``channels`` how many channels it has (``None``: not known until it answers; see
    :meth:`check_channels`). Problems raise :class:`DriverConfigError`.
    """

    def __init__(
        self,
        profile: Profile,
        *,
        board: str,
        step_us: float,
        range_us: tuple[float, float],
        channels: int | None,
    ) -> None:
        self.board = board
        self.step_us = step_us
        self.profile_name = profile.name
        self.channel: dict[str, int] = {}
        self.limits: dict[int, ChannelLimits] = {}
        low_us, high_us = range_us
        for spec in profile.servos:
            low = math.ceil(spec.min_us / step_us - 1e-9)
            high = math.floor(spec.max_us / step_us + 1e-9)
            if low * step_us < low_us or high * step_us > high_us or low > high:
                raise DriverConfigError(
                    f"servo {spec.name!r} (channel {spec.channel}): limits "
                    f"{spec.min_us:g}..{spec.max_us:g} us are outside what the {board} drives "
                    f"({low_us:g}..{high_us:g} us)"
                )
            neutral = min(max(round(spec.neutral_us / step_us), low), high)
            self.channel[spec.name] = spec.channel
            self.limits[spec.channel] = ChannelLimits(spec.name, low, neutral, high)
        if channels is not None:
            self.check_channels(channels)

    @property
    def channels(self) -> list[int]:
        """The channels the profile uses, ascending."""
        return sorted(self.limits)

    def check_channels(self, channels: int, board: str | None = None) -> None:
        """Raise :class:`DriverConfigError` unless every servo's channel is below ``channels``."""
        beyond = [ch for ch in self.channels if ch >= channels]
        if beyond:
            ch = beyond[-1]
            raise DriverConfigError(
                f"profile {self.profile_name!r} puts servo {self.limits[ch].name!r} on channel "
                f"{ch}, but the {board or self.board} has channels 0..{channels - 1}"
            )

    def neutral_pose(self) -> dict[int, int]:
        """Every channel at its neutral, in board units."""
        return {ch: lim.neutral for ch, lim in self.limits.items()}

    def pose(self, positions: Mapping[str, float], previous: Mapping[int, int]) -> dict[int, int]:
        """``previous`` updated with ``positions`` (µs by servo name), rounded and clamped.

        Unknown servo names and non-finite values raise :class:`DriverError` (nothing is sent).
        """
        pose = dict(previous)
        for name, us in positions.items():
            ch = self.channel.get(name)
            if ch is None:
                raise DriverError(f"servo {name!r} is not in profile {self.profile_name!r}")
            if not math.isfinite(us):
                raise DriverError(f"position of {name!r} is {us}")
            pose[ch] = self.limits[ch].clamp(round(us / self.step_us))
        return pose

    def us(self, units: int) -> float:
        """Board units back to microseconds."""
        return units * self.step_us

    def checked(self, pose: Mapping[int, int]) -> dict[int, int]:
        """``pose`` restricted to the profile's channels and clamped: the last step before
        encoding, so even a pose built elsewhere cannot leave the limits."""
        return {ch: self.limits[ch].clamp(int(pose[ch])) for ch in self.channels if ch in pose}


class ProfileLimits:
    """The safety check of drivers without board units (files, pages, avatars): positions by
    servo name, clamped to the profile's limits; unknown servos and non-finite values raise
    :class:`DriverError`, so nothing is half sent."""

    def __init__(self, profile: Profile) -> None:
        self.profile_name = profile.name
        self.specs = {spec.name: spec for spec in profile.servos}
        #: Each servo's limits, looked up once (every command is clamped to them).
        self._limits = {spec.name: (spec.min_us, spec.max_us) for spec in profile.servos}

    def clamp(self, positions: Mapping[str, float]) -> dict[str, float]:
        """``positions`` checked and clamped."""
        out = {}
        limits = self._limits
        for name, value in positions.items():
            bounds = limits.get(name)
            if bounds is None:
                raise DriverError(f"servo {name!r} is not in profile {self.profile_name!r}")
            if not math.isfinite(value):
                raise DriverError(f"position of {name!r} is {value}")
            out[name] = min(max(value, bounds[0]), bounds[1])  # ServoSpec.clamp
        return out
