"""The rig console's pure core: where the console wants each servo, and the profile being edited.

The console jogs servos through the control interface C (it publishes ``ServoCommands`` like a
translator), so C's clamping, speed limits and watchdog hold. :class:`ConsoleRig` keeps

* ``active``: the profile C runs (its limits are what C enforces);
* ``draft``: the same profile with the user's edits (limits set from where a servo stands,
  names, reversal), validated after every edit and saved by :mod:`.profile_file`;
* ``targets``: where the console asks the servos to be while it ``holding`` them, each clamped
  to the narrower of the active and the draft limits (a limit widened in the draft takes
  effect once the profile is saved and C restarts with it);
* ``positions``: where C reported the servos last (``…/servo_state``);
* ``measured`` and ``faults``: what the servos themselves reported in C's last report (smart
  bus servos read their position back; other drivers report nothing).

Servos are addressed by their index in the profile (a rename does not move a slider). Every
refused request raises :class:`ConsoleError` with a message for the page.
"""

from __future__ import annotations

import math
from typing import Literal

import msgspec

from facesynth.runtime.profiles import Profile, ServoSpec, validate_profile

Limit = Literal["min", "neutral", "max"]
FIELDS: dict[Limit, str] = {"min": "min_us", "neutral": "neutral_us", "max": "max_us"}
#: Longest servo name the console accepts (a profile key, shown in tables).
MAX_NAME = 40


class ConsoleError(ValueError):
    """A console request that cannot be done; the message says why, for the page."""


class ConsoleRig:
    """Jog targets and the draft profile of one rig (see the module docstring)."""

    def __init__(self, profile: Profile) -> None:
        if profile.learned is not None:
            raise ConsoleError(
                f"profile {profile.name!r} is learned: edit the hardware profile it was "
                "learned on (its TOML) instead"
            )
        self.active = profile
        self.draft = msgspec.structs.replace(profile, servos=[_copy(s) for s in profile.servos])
        self.positions: dict[str, float] = profile.neutral_positions()
        self.measured: dict[str, float] = {}
        self.faults: dict[str, str] = {}
        self.targets: list[float] = [spec.neutral_us for spec in profile.servos]
        self.holding = False
        self.dirty = False

    # --- where the servos are and should be -------------------------------------------------

    def report(
        self,
        profile_name: str,
        positions: dict[str, float],
        measured: dict[str, float] | None = None,
        faults: dict[str, str] | None = None,
    ) -> None:
        """C's report of where the servos are commanded and, where they read themselves back,
        measured (each report replaces the last readings; other profiles' are ignored)."""
        if profile_name == self.active.name:
            self.positions.update(
                {k: v for k, v in positions.items() if isinstance(v, float | int)}
            )
            self.measured = {
                k: float(v) for k, v in (measured or {}).items() if isinstance(v, float | int)
            }
            self.faults = {k: v for k, v in (faults or {}).items() if isinstance(v, str)}

    def read_back(self, index: int) -> tuple[float | None, str]:
        """Servo ``index``'s measured position (None: not read back) and fault ("": none)."""
        name = self.active.servos[self._index(index)].name
        return self.measured.get(name), self.faults.get(name, "")

    def here(self, index: int) -> float:
        """Where servo ``index`` stands (C's last report)."""
        spec = self.active.servos[self._index(index)]
        return float(self.positions.get(spec.name, spec.neutral_us))

    def bounds(self, index: int) -> tuple[float, float]:
        """The range a jog of servo ``index`` may reach now: active ∩ draft limits."""
        active, draft = self.active.servos[index], self.draft.servos[index]
        low, high = max(active.min_us, draft.min_us), min(active.max_us, draft.max_us)
        return (low, high) if low <= high else (active.neutral_us, active.neutral_us)

    def hold(self) -> None:
        """Start holding the servos where they stand."""
        if not self.holding:
            self.targets = [self._clamp(i, self.here(i)) for i in range(len(self.targets))]
            self.holding = True

    def release(self) -> None:
        """Stop commanding (C's watchdog returns the face to neutral, or the chain drives it)."""
        self.holding = False

    def jog(self, index: int, us: float) -> float:
        """Ask servo ``index`` to go to ``us`` (clamped); returns the target it got."""
        index = self._index(index)
        if not math.isfinite(us):
            raise ConsoleError(f"a position must be a finite number of µs, not {us}")
        self.hold()
        self.targets[index] = self._clamp(index, us)
        return self.targets[index]

    def centre_all(self) -> None:
        """Every servo to the middle of its range."""
        self.hold()
        self.targets = [self._clamp(i, sum(self.bounds(i)) / 2) for i in range(len(self.targets))]

    def neutral_all(self) -> None:
        """Every servo to its (draft) neutral."""
        self.hold()
        self.targets = [self._clamp(i, spec.neutral_us) for i, spec in enumerate(self.draft.servos)]

    def stop_all(self) -> None:
        """Every servo stops where it stands (held there)."""
        self.holding = True
        self.targets = [self._clamp(i, self.here(i)) for i in range(len(self.targets))]

    def commands(self) -> dict[str, float]:
        """The positions to send C (by the active profile's names)."""
        return {spec.name: t for spec, t in zip(self.active.servos, self.targets, strict=True)}

    # --- editing the draft ----------------------------------------------------------------

    def set_limit(self, index: int, which: Limit, us: float | None = None) -> float:
        """Set servo ``index``'s ``min``/``neutral``/``max`` to ``us`` (default: where it
        stands); refused when the profile would not be valid. Returns the value set."""
        index = self._index(index)
        if which not in FIELDS:
            raise ConsoleError(f"a limit is min, neutral or max, not {which!r}")
        value = self.here(index) if us is None else us
        if not math.isfinite(value):
            raise ConsoleError(f"a limit must be a finite number of µs, not {value}")
        value = round(float(value), 1)
        self._edit(index, **{FIELDS[which]: value})
        self.targets[index] = self._clamp(index, self.targets[index])
        return value

    def rename(self, index: int, name: str) -> None:
        """Give servo ``index`` a new name (unique; letters, digits, ``_`` and ``-``)."""
        index = self._index(index)
        name = name.strip()
        if not name or len(name) > MAX_NAME or not all(c.isalnum() or c in "_-" for c in name):
            raise ConsoleError(
                f"a servo name is 1 to {MAX_NAME} letters, digits, '_' or '-', not {name!r}"
            )
        self._edit(index, name=name)

    def reverse(self, index: int, reversed_: bool) -> None:
        """Mark servo ``index`` as wired the other way round (or not)."""
        self._edit(self._index(index), reversed=bool(reversed_))

    def saved(self, profile: Profile) -> None:
        """The draft was saved as ``profile`` and C now runs it."""
        old = self.active
        self.active = profile
        self.draft = msgspec.structs.replace(profile, servos=[_copy(s) for s in profile.servos])
        self.positions = {
            spec.name: self.positions.get(before.name, spec.neutral_us)
            for spec, before in zip(profile.servos, old.servos, strict=True)
        }
        self.targets = [self._clamp(i, t) for i, t in enumerate(self.targets)]
        self.dirty = False

    def servo_rows(self) -> list[dict[str, object]]:
        """Each servo as the page lists it (draft values, and the range a jog reaches now)."""
        rows: list[dict[str, object]] = []
        for i, spec in enumerate(self.draft.servos):
            low, high = self.bounds(i)
            rows.append(
                {
                    "index": i,
                    "name": spec.name,
                    "channel": spec.channel,
                    "min": spec.min_us,
                    "neutral": spec.neutral_us,
                    "max": spec.max_us,
                    "reversed": spec.reversed,
                    "low": low,
                    "high": high,
                    "active_min": self.active.servos[i].min_us,
                    "active_max": self.active.servos[i].max_us,
                }
            )
        return rows

    # --- internals ----------------------------------------------------------------------

    def _index(self, index: int) -> int:
        if isinstance(index, bool) or not isinstance(index, int):
            raise ConsoleError(f"a servo is given by its index, not {index!r}")
        if not 0 <= index < len(self.draft.servos):
            raise ConsoleError(
                f"no servo {index}: profile {self.draft.name!r} has servos "
                f"0..{len(self.draft.servos) - 1}"
            )
        return index

    def _clamp(self, index: int, us: float) -> float:
        low, high = self.bounds(index)
        return min(max(float(us), low), high)

    def _edit(self, index: int, **changes: object) -> None:
        servos = list(self.draft.servos)
        servos[index] = msgspec.structs.replace(servos[index], **changes)
        candidate = msgspec.structs.replace(self.draft, servos=servos)
        problems = validate_profile(candidate)
        if problems:
            raise ConsoleError("; ".join(problems))
        self.draft = candidate
        self.dirty = True


def _copy(spec: ServoSpec) -> ServoSpec:
    return msgspec.structs.replace(spec)
