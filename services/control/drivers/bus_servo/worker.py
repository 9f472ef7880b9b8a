"""The bus thread: it owns a smart servo bus (the vendor SDKs block), lending it for pose writes.

It opens the port, pings every servo of the profile and checks its model, sets the profile
velocity/acceleration and turns the torque on, then serves. Each pose goes out as one Sync
Write, written by :meth:`BusWorker.submit` in the caller's thread when the bus is free (about
100 bytes into the port's buffer: no wait, no thread to wake), else by the thread. A read-back
of as many servos as fit in the read budget (round robin) follows a write at most every
``read_period_s`` (default: the bus's :meth:`~.ServoBus.read_hz`; with no pose for two
periods, it comes on its own): parsing answers costs C CPU, so it runs at its own rate. A
port that fails, or a bus where no servo has answered for :data:`SILENT_S`, is reopened with
backoff; the pose held is written again on reconnect.

A servo reporting a hardware error (overload, overheating, voltage) is held: its goal is no
longer written, one line is logged, the others go on; it moves again once the error clears.
A servo that misses three read-backs in a row shows as "not answering" and is asked again once
a second (:mod:`facesynth.services.control.drivers.bus_servo.health` keeps this account).
"""

from __future__ import annotations

import concurrent.futures
import logging
import termios
import threading
import time
from collections.abc import Callable, Mapping
from typing import Any

import serial

from facesynth.services.control.drivers.base import (
    DeviceUnavailable,
    DriverConfigError,
    DriverError,
)
from facesynth.services.control.drivers.bus_servo.budget import read_chunk
from facesynth.services.control.drivers.bus_servo.bus import Ping, ServoBus, Status
from facesynth.services.control.drivers.bus_servo.health import (
    NOT_ANSWERING,
    SILENT_S,
    ServoHealth,
)
from facesynth.services.control.drivers.bus_servo.models import check_answers
from facesynth.services.control.drivers.bus_servo.native import Model, NativePose
from facesynth.services.control.drivers.serial_link import Backoff, LinkState, _reason

#: Errors after which the thread reopens the port (termios: a pty or adapter gone mid-call).
TRANSIENT = (OSError, serial.SerialException, TimeoutError, DriverError, termios.error)
PING_TRIES = 3


class BusWorker:
    """One bus thread for one driver connection (see the module docstring)."""

    def __init__(
        self,
        bus: ServoBus,
        pose: NativePose,
        *,
        port: str,
        baud: int,
        limits: Mapping[int, tuple[float, float]],
        read_budget_s: float,
        read_period_s: float | None,
        log: logging.Logger,
    ) -> None:
        self.bus = bus
        self.map = pose
        self.port = port
        self.baud = baud
        self.limits = dict(limits)  # id -> (max_speed µs/s, max_accel µs/s²)
        self.read_budget_s = read_budget_s
        self.read_period_s = read_period_s
        self.log = log
        self.state = LinkState(port)
        self.query_only = False
        self.found: dict[int, Model] = {}
        #: The last connection's pings, and (read-only connections) what cannot serve the
        #: profile, by id.
        self.answers: dict[int, Ping | None] = {}
        self.problems: dict[int, str] = {}
        self.reads = 0
        #: Counts every change of the statuses or faults (the driver rebuilds its readings).
        self.version = 0
        #: Poses replaced by a newer one before the bus thread could write them.
        self.overtaken = 0
        self._lock = threading.Condition()
        #: Held by whoever uses the port (the thread, or :meth:`submit` writing a pose).
        self._bus_lock = threading.Lock()
        self._goal_us: dict[str, float] = {}
        self._dirty = False
        self._stop = False
        self._relax = False
        self._calls: list[tuple[Callable[[ServoBus], Any], concurrent.futures.Future[Any]]] = []
        self.health = ServoHealth()
        self._next_read = 0.0
        self._read_due = False  # a pose was just written and a read-back is due
        self._last_write = 0.0
        self._thread: threading.Thread | None = None

    # -- the driver's side (event loop) ------------------------------------------------------

    def start(
        self, pose_us: Mapping[str, float], *, retry: bool
    ) -> concurrent.futures.Future[None]:
        """Start the thread; the future says how the first connection went (with ``retry``,
        a device that cannot be opened is waited for and the future succeeds)."""
        self._goal_us = dict(pose_us)
        self._dirty = True
        first: concurrent.futures.Future[None] = concurrent.futures.Future()
        self._thread = threading.Thread(
            target=self._run, args=(first, retry), name=f"bus {self.port}", daemon=True
        )
        self._thread.start()
        return first

    def submit(self, pose_us: Mapping[str, float]) -> None:
        """The pose to write next (µs by name, checked and clamped): written now when the bus
        is connected and free, else handed to the thread."""
        with self._lock:
            if self._dirty and self.state.connected:
                self.overtaken += 1  # the bus was busy: the newer pose goes instead
            self._goal_us = dict(pose_us)
            self._dirty = True
            free = self.state.connected and not self._stop and self._bus_lock.acquire(False)
            if not free:
                self._lock.notify()
                return
            goals = self._take_goals()
        try:
            if goals:
                self.bus.write_goals(goals)
                self._last_write = time.monotonic()
        except TRANSIENT:
            with self._lock:  # the thread writes it again and finds out what the port has
                self._dirty = True
                self._lock.notify()
        finally:
            self._bus_lock.release()
        if self._last_write >= self._next_read:  # the read-back goes right after this write
            with self._lock:
                self._read_due = True
                self._lock.notify()

    def call(self, fn: Callable[[ServoBus], Any]) -> concurrent.futures.Future[Any]:
        """Run ``fn(bus)`` on the bus thread between frames."""
        future: concurrent.futures.Future[Any] = concurrent.futures.Future()
        with self._lock:
            if not self.state.connected:
                future.set_exception(DriverError(f"{self.port}: {self.state.describe()}"))
            else:
                self._calls.append((fn, future))
                self._lock.notify()
        return future

    def stop(self, *, relax: bool) -> None:
        """Write what is pending (the neutral face), relax if asked, close; blocks."""
        with self._lock:
            self._stop = True
            self._relax = relax
            self._lock.notify()
        if self._thread is not None:
            self._thread.join(timeout=10)

    def snapshot(self) -> tuple[dict[int, Status], dict[int, str]]:
        """The latest status of each servo read, and the faults (by id)."""
        with self._lock:
            return dict(self.health.statuses), dict(self.health.faults)

    # -- the bus thread ------------------------------------------------------------------------

    def _run(self, first: concurrent.futures.Future[None], retry: bool) -> None:
        backoff = Backoff()
        try:
            while not self._stopping():
                try:
                    with self._bus_lock:
                        self._connect()
                except (DriverConfigError, *TRANSIENT) as exc:
                    self._close()
                    fatal = not retry or (isinstance(exc, DriverConfigError) and not first.done())
                    self._failed(exc, first, fatal)
                    if fatal:
                        return
                    if not first.done():
                        first.set_result(None)
                    self._wait(backoff.next())
                    continue
                backoff.reset()
                if not first.done():
                    first.set_result(None)
                try:
                    self._serve()
                except TRANSIENT as exc:
                    self._lost(exc)
                    if not retry:
                        return
                    continue
                return
        finally:
            self._finish()
            if not first.done():
                first.set_exception(DriverError(f"{self.port}: closed"))

    def _stopping(self) -> bool:
        with self._lock:
            return self._stop

    def _wait(self, seconds: float) -> None:
        with self._lock:
            if not self._stop:
                self._lock.wait(seconds)

    def _failed(
        self, exc: BaseException, first: concurrent.futures.Future[None], fatal: bool
    ) -> None:
        self.state.failed_attempts += 1
        reason = _reason(exc)
        if reason != self.state.last_error and not fatal:
            level = logging.ERROR if isinstance(exc, DriverConfigError) else logging.WARNING
            self.log.log(level, "%s: %s; still trying", self.port, reason)
        self.state.last_error = reason
        if fatal and not first.done():
            if isinstance(exc, DriverConfigError):
                first.set_exception(exc)
            else:
                first.set_exception(DeviceUnavailable(f"{self.port}: {reason}"))

    def _lost(self, exc: BaseException) -> None:
        with self._lock:
            self.state.connected = False
        self.state.losses += 1
        self.state.last_error = _reason(exc)
        self.log.warning(
            "%s: bus lost (%s); reconnecting, commands are held meanwhile", self.port, _reason(exc)
        )
        self._close()

    def _connect(self) -> None:
        self.bus.open()
        ids = sorted(self.map.ids.items(), key=lambda item: item[1])
        answers = {servo_id: self.bus.ping(servo_id) for _, servo_id in ids}
        for _ in range(PING_TRIES - 1):  # a lost or garbled answer is asked again
            for servo_id in [i for i, answer in answers.items() if answer is None]:
                answers[servo_id] = self.bus.ping(servo_id)
        self.answers = answers
        self.problems = {}
        missing = [(name, i) for name, i in ids if answers[i] is None]
        if len(missing) == len(ids):
            raise TimeoutError(f"no servo answers (ids {', '.join(str(i) for _, i in ids)})")
        if missing and self.query_only:
            self.problems.update((i, f"does not answer at {self.baud} baud") for _, i in missing)
        elif missing:
            found = ", ".join(str(i) for _, i in ids if answers[i] is not None)
            name, servo_id = missing[0]
            raise DriverConfigError(
                f"servo {name!r} (id {servo_id}) does not answer on {self.port} "
                f"(answering: ids {found}; {len(missing)} missing)"
            )
        models, problems = check_answers(self.bus, self.map, answers, strict=not self.query_only)
        self.problems.update(problems)
        self.problems.update(self.map.bind(models, strict=not self.query_only))
        self.found = models
        if not self.query_only:
            for servo_id, servo in self.map.servos.items():
                speed, accel = self.limits[servo_id]
                self.bus.prepare(servo, speed, accel)
        now = time.monotonic()
        with self._lock:
            faults = {i: p.fault for i, p in answers.items() if p is not None and p.fault}
            self.health.connected(faults, self.map.servos, now)
            self.version += 1
            self.state.connected = True
            self.state.connects += 1
            self.state.failed_attempts = 0
            self.state.last_error = ""
            self._dirty = not self.query_only
        for servo_id, fault in self.health.faults.items():
            self.log.warning("%s: %s; holding it", self.port, self._who(servo_id, fault))

    def _serve(self) -> None:
        ids = sorted(self.map.servos)
        chunk = read_chunk(self.bus.read_bytes, len(ids), self.baud, self.read_budget_s)
        period = self.read_period_s or 1 / self.bus.read_hz(ids)
        turn = 0
        while True:
            with self._lock:
                if not (self._dirty or self._stop or self._calls or self._read_due):
                    # Idle (no pose for two read periods): the read-back comes on its own.
                    idle_read = max(self._next_read, self._last_write + 2 * period)
                    self._lock.wait(max(0.0, idle_read - time.monotonic()))
                stop, calls, self._calls = self._stop, self._calls, []
                read_due, self._read_due = self._read_due, False
            with self._bus_lock:
                with self._lock:
                    goals = self._take_goals()
                for fn, future in calls:
                    try:
                        future.set_result(fn(self.bus))
                    except TRANSIENT as exc:
                        future.set_exception(exc)
                        raise
                if goals:
                    self.bus.write_goals(goals)
                    self._last_write = time.monotonic()
                if stop:
                    if self._relax:
                        self.bus.relax(ids)
                    return
                now = time.monotonic()
                idle = now - self._last_write >= 2 * period
                if (goals or read_due or idle) and now >= self._next_read:
                    # After a write (one a frame at most) or when idle; due 10 % early, so
                    # 30 poses/s and 15 reads/s read at every other frame despite jitter.
                    self._next_read = now + period * 0.9
                    asked = self.health.pick(ids, turn, chunk, now)
                    turn += chunk
                    if asked:
                        self._update(self.bus.read(asked), now)
            if self.health.silent(now):
                raise TimeoutError(f"no servo answered for {SILENT_S:g} s")

    def _take_goals(self) -> dict[int, int]:
        if not self._dirty or self.query_only:
            return {}
        self._dirty = False
        goals = {}
        ids, servos, faults = self.map.ids, self.map.servos, self.health.faults
        for name, us in self._goal_us.items():
            servo_id = ids[name]
            if faults and faults.get(servo_id, NOT_ANSWERING) != NOT_ANSWERING:
                continue  # held
            goals[servo_id] = servos[servo_id].native(us)
        return goals

    def _update(self, statuses: Mapping[int, Status | None], now: float) -> None:
        with self._lock:
            self.reads += 1
            self.version += 1
            said = self.health.update(statuses, now)
            if any(not fault for _, _, fault in said):
                self._dirty = True  # write the held servo's goal again
        for servo_id, before, fault in said:
            if fault and fault != NOT_ANSWERING:
                self.log.warning(
                    "%s: %s; holding it, the other servos go on",
                    self.port,
                    self._who(servo_id, fault),
                )
            elif fault:
                self.log.warning("%s: %s", self.port, self._who(servo_id, fault))
            else:
                self.log.info("%s: %s", self.port, self._who(servo_id, f"{before} cleared"))

    def _who(self, servo_id: int, what: str) -> str:
        name = next((n for n, i in self.map.ids.items() if i == servo_id), "?")
        return f"servo {name!r} (id {servo_id}): {what}"

    def _finish(self) -> None:
        with self._lock:
            self.state.connected = False
            calls, self._calls = self._calls, []
        for _, future in calls:
            future.set_exception(DriverError(f"{self.port}: closed"))
        self._close()

    def _close(self) -> None:
        with self._bus_lock:  # never under a pose being written
            self.bus.close()
