"""Speed and acceleration bounds on a position, pure: shared by the translator and the controller.

:func:`limit_step` moves a position toward a target no faster than ``max_speed`` and with a speed
that changes no faster than ``max_accel``, braking so it stops at the target (0 = unlimited).
The translator limits its targets on the media clock; the control interface limits again, on its
own clock, right before the servos (``services.control.motion``), so nothing upstream can step a
servo faster than its profile allows.
"""

from __future__ import annotations

import math

#: Above this many ``dt·step`` units of distance, :func:`braking_speed` solves in closed form.
EXACT_BUDGET = 2.0**50


def braking_speed(distance: float, max_accel: float, dt_s: float) -> float:
    """The largest speed ``v`` from which steps of ``dt_s`` at ``v, v - a·dt, v - 2a·dt, …``
    (while positive) cover at most ``distance`` (>= 0): moving at it now, the limiter can still
    stop at the target."""
    step = max_accel * dt_s
    if distance <= 0:
        return 0.0
    if dt_s * step <= 0:  # an acceleration bound so small its speed change is 0: no speed
        return 0.0
    # Covered from v = (k + f)·step, 0 <= f < 1: dt·step·((k + 1)·f + k(k + 1)/2).
    budget = distance / (dt_s * step)
    if not math.isfinite(budget):  # (denormal steps) far below any speed that moves a servo
        return 0.0
    if budget > EXACT_BUDGET:
        # k(k + 1)/2 is past the floats' whole numbers, so stepping k by 1 would not change it
        # (the loops below would never end): the continuous bound, covering at most an eighth
        # of a step less than the exact one, which is as good at this many steps.
        return max(0.0, math.sqrt(2.0 * distance * max_accel) - step / 2.0)
    k = math.floor((math.sqrt(8.0 * budget + 1.0) - 1.0) / 2.0)
    while k * (k + 1) / 2 > budget:
        k -= 1
    while (k + 1) * (k + 2) / 2 <= budget:
        k += 1
    fraction = (budget - k * (k + 1) / 2) / (k + 1)
    return (k + min(fraction, 1.0)) * step


def limit_step(
    position: float,
    velocity: float,
    target: float,
    dt_s: float,
    max_speed: float = 0.0,
    max_accel: float = 0.0,
) -> tuple[float, float]:
    """``(position, velocity)`` after one step of ``dt_s`` toward ``target``.

    ``max_speed`` (units/s) and ``max_accel`` (units/s²) bound the move; 0 means unlimited.
    ``dt_s <= 0`` does not move.
    """
    if dt_s <= 0:
        return position, velocity
    error = target - position
    speed = abs(error) / dt_s  # reach the target in this step, no overshoot
    if max_speed > 0:
        speed = min(speed, max_speed)
    if max_accel > 0:
        speed = min(speed, braking_speed(abs(error), max_accel, dt_s))
        wanted = math.copysign(speed, error)
        change = max_accel * dt_s
        new_velocity = min(max(wanted, velocity - change), velocity + change)
    else:
        new_velocity = math.copysign(speed, error)
    new_position = position + new_velocity * dt_s
    if max_accel <= 0 and (target - new_position) * error <= 0:
        new_position = target  # reached (without an acceleration bound, never past it)
    return new_position, new_velocity
