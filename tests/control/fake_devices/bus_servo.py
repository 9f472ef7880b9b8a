"""One emulated smart servo (Dynamixel or Feetech): a control table, a motor that moves, faults.

The control table is the servo's memory as its manufacturer documents it: a :class:`Layout`
says where each item lives (ROBOTIS e-manual control tables for the XL430/XM430 and the
AX-12A/MX-28, Feetech's STS3215/SCS0009 memory tables) and in which byte order. Reads and
writes go through :meth:`EmulatedServo.read` / :meth:`EmulatedServo.write`, which answer with
the protocol's error (EEPROM written while the torque is on, a read-only item, a goal beyond
the position limits).

The motor turns towards the goal while the torque is on, at the profile velocity (or 1 rev/s
when that is 0). A servo given a ``stall_at`` position stops there (blocked by the skin), its
load rises to 100 %, and after :attr:`STALL_OVERLOAD_S` it reports an overload and turns its
torque off, as the factory Shutdown setting does. ``silent`` makes it stop answering.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

#: Access errors a control table answers with (each framing maps them to its own bits).
ACCESS = "access"
LIMIT = "limit"
RANGE = "range"


@dataclass(frozen=True)
class Layout:
    """Where a servo family keeps each item of its control table."""

    model_addr: int
    id_addr: int
    eeprom_end: int  # addresses below: written only with the torque off
    torque: int
    goal: int
    goal_size: int
    present_position: int
    position_size: int
    load: int
    temperature: int
    voltage: int
    min_limit: int
    max_limit: int
    limit_size: int
    read_only: tuple[tuple[int, int], ...]  # [start, end) ranges
    velocity: int | None = None  # profile velocity / moving speed
    velocity_size: int = 2
    acceleration: int | None = None
    acceleration_size: int = 1
    hardware_error: int | None = None
    big_endian: bool = False
    load_sign_bit: int | None = 10  # None: two's complement
    moving: int | None = None


#: Dynamixel X series (XL430-W250, XM430-W350), Protocol 2.0.
X_SERIES = Layout(
    model_addr=0,
    id_addr=7,
    eeprom_end=64,
    torque=64,
    goal=116,
    goal_size=4,
    present_position=132,
    position_size=4,
    load=126,
    temperature=146,
    voltage=144,
    min_limit=52,
    max_limit=48,
    limit_size=4,
    read_only=((0, 7), (70, 71), (120, 147)),
    velocity=112,
    velocity_size=4,
    acceleration=108,
    acceleration_size=4,
    hardware_error=70,
    load_sign_bit=None,
    moving=122,
)
#: Dynamixel AX-12A / MX-28 (Protocol 1.0); MX has goal acceleration at 73.
AX_SERIES = Layout(
    model_addr=0,
    id_addr=3,
    eeprom_end=24,
    torque=24,
    goal=30,
    goal_size=2,
    present_position=36,
    position_size=2,
    load=40,
    temperature=43,
    voltage=42,
    min_limit=6,
    max_limit=8,
    limit_size=2,
    read_only=((0, 3), (36, 44), (46, 47)),
    velocity=32,
    moving=46,
)
#: Feetech STS (STS3215, STS3032; little-endian) and SCS (SCS0009; big-endian) memory tables.
STS_SERIES = Layout(
    model_addr=3,
    id_addr=5,
    eeprom_end=40,
    torque=40,
    goal=42,
    goal_size=2,
    present_position=56,
    position_size=2,
    load=60,
    temperature=63,
    voltage=62,
    min_limit=9,
    max_limit=11,
    limit_size=2,
    read_only=((0, 5), (56, 71)),
    velocity=46,
    acceleration=41,
    moving=66,
)
SCS_SERIES = Layout(**{**STS_SERIES.__dict__, "acceleration": None, "big_endian": True})

HW_OVERLOAD = 1 << 5
HW_OVERHEATING = 1 << 2
HW_VOLTAGE = 1 << 0


@dataclass
class EmulatedServo:
    """One servo on an emulated bus."""

    servo_id: int
    model: int
    layout: Layout
    resolution: int  # positions per turn of the table's range (4096, 1024)
    units_per_s: float = 4096.0  # speed when the profile velocity is 0
    velocity_unit: float = 0.229 / 60 * 4096  # position units/s per velocity unit
    table: bytearray = field(default_factory=lambda: bytearray(256))
    stall_at: int | None = None
    silent: bool = False
    temperature_c: int = 32
    voltage_dv: int = 120
    STALL_OVERLOAD_S = 0.2

    def __post_init__(self) -> None:
        self.present = float(self.resolution // 2)
        self.stalled_since: float | None = None
        self.load_permille = 0
        self.errors = 0  # overload / overheating / voltage, as a hardware error status
        self.writes: list[tuple[int, bytes]] = []
        self._last = time.monotonic()
        self.put(self.layout.model_addr, 2, self.model)
        self.put(self.layout.id_addr, 1, self.servo_id)
        self.put(self.layout.min_limit, self.layout.limit_size, 0)
        self.put(self.layout.max_limit, self.layout.limit_size, self.resolution - 1)
        self.put(self.layout.goal, self.layout.goal_size, int(self.present))
        self._sync_present()

    # -- the table -------------------------------------------------------------------------

    def get(self, addr: int, size: int) -> int:
        data = bytes(self.table[addr : addr + size])
        return int.from_bytes(data, "big" if self.layout.big_endian else "little")

    def put(self, addr: int, size: int, value: int) -> None:
        order = "big" if self.layout.big_endian else "little"
        self.table[addr : addr + size] = (value & ((1 << 8 * size) - 1)).to_bytes(size, order)

    @property
    def torque_on(self) -> bool:
        return bool(self.table[self.layout.torque])

    @property
    def goal(self) -> int:
        return self.get(self.layout.goal, self.layout.goal_size)

    def read(self, addr: int, size: int) -> bytes | str:
        """``size`` bytes from ``addr``, or an error name."""
        if size <= 0 or addr + size > len(self.table):
            return ACCESS
        self.advance()
        return bytes(self.table[addr : addr + size])

    def write(self, addr: int, data: bytes) -> str:
        """Write ``data`` at ``addr``; an error name, or "" when done."""
        lay = self.layout
        end = addr + len(data)
        if not data or end > len(self.table):
            return ACCESS
        if any(addr < stop and end > start for start, stop in lay.read_only):
            return ACCESS
        if addr < lay.eeprom_end and self.torque_on:
            return ACCESS
        self.advance()
        shadow = bytearray(self.table)
        shadow[addr:end] = data
        order = "big" if lay.big_endian else "little"
        goal_end = lay.goal + lay.goal_size
        if addr < goal_end and end > lay.goal:
            goal = int.from_bytes(shadow[lay.goal : goal_end], order, signed=True)
            low = self.get(lay.min_limit, lay.limit_size)
            high = self.get(lay.max_limit, lay.limit_size)
            if not low <= goal <= high:
                return LIMIT
        if addr <= lay.torque < end and shadow[lay.torque] > 1:
            return RANGE
        self.table[addr:end] = data
        self.writes.append((addr, bytes(data)))
        if addr <= lay.torque < end and not data[lay.torque - addr]:
            self.stalled_since = None
        return ""

    # -- the motor -------------------------------------------------------------------------

    def speed(self) -> float:
        lay = self.layout
        if lay.velocity is None:
            return self.units_per_s
        value = self.get(lay.velocity, lay.velocity_size)
        return value * self.velocity_unit if value else self.units_per_s

    def advance(self, now: float | None = None) -> None:
        """Move the motor to where it is at ``now``."""
        now = time.monotonic() if now is None else now
        dt, self._last = max(0.0, now - self._last), now
        if self.torque_on and not self.errors:
            target = float(self.goal)
            step = self.speed() * dt
            delta = max(-step, min(step, target - self.present))
            new = self.present + delta
            stall = self.stall_at
            if stall is not None and min(self.present, new) <= stall <= max(self.present, new):
                if delta:
                    new = float(stall)
                if new == stall and target != stall:
                    self.stalled_since = self.stalled_since or now
                    if now - self.stalled_since >= self.STALL_OVERLOAD_S:
                        self.errors |= HW_OVERLOAD
                        self.table[self.layout.torque] = 0  # Shutdown: torque off
            else:
                self.stalled_since = None
            self.load_permille = 0
            if self.stalled_since is not None:
                self.load_permille = 1000 if target > stall else -1000  # type: ignore[operator]
            elif delta:
                self.load_permille = 200 if delta > 0 else -200
            self.present = new
        if self.temperature_c >= 70:
            self.errors |= HW_OVERHEATING
        self._sync_present()

    def _sync_present(self) -> None:
        lay = self.layout
        self.put(lay.present_position, lay.position_size, round(self.present))
        load = self.load_permille
        if lay.load_sign_bit is None:
            self.put(lay.load, 2, load)
        else:
            self.put(lay.load, 2, abs(load) | ((1 << lay.load_sign_bit) if load < 0 else 0))
        self.table[lay.temperature] = self.temperature_c
        if lay.voltage == 144:
            self.put(lay.voltage, 2, self.voltage_dv)
        else:
            self.table[lay.voltage] = self.voltage_dv
        if lay.hardware_error is not None:
            self.table[lay.hardware_error] = self.errors
        if lay.moving is not None:
            self.table[lay.moving] = int(round(self.present) != self.goal)
