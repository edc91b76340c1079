"""The machine's timing as Rowe's script parameters use it (Rowe 1997 §4.2), and the swing's set-point profile.

The boom trigger of Fig. 4 lets the swing start before the boom is clear of the truck, timed so that the
boom, rising at its speed, passes the clearance angle when the swing reaches the truck's near edge; the
bucket-open lead says how far before the dump angle the bucket starts to open. Both come from a model of
how long the joints take (a :class:`MachineTiming`):

* :class:`TimingModel` (the T3): each joint at its flow-limited speed, then the servo's exponential
  approach, after a latency; the lead is computed so that the bucket is half open as the swing arrives.
* :class:`ProfileTiming` (the 25 t): the swing follows its :class:`SwingProfile`, the boom rises at its
  flow-limited speed; the lead is a fixed angle.

The swing of a 25 t machine is torque-limited (its relief torque over the upper structure's inertia
gives about 0.3 rad/s^2), so a step command overshoots by half a radian (the world's hydraulics have no
deceleration valve). :class:`SwingProfile` is the controller's answer (assumed, as an operator eases off):
the swing's set-point follows a trapezoidal profile of ``accel`` and ``speed`` towards the script's
command (:class:`SwingTracker`); the other joints get the script's commands as steps, as Rowe's PD
controller did (§4.0).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Protocol

import numpy as np


class MachineTiming(Protocol):
    """The machine model of §4.2 as the script's parameters read it."""

    def swing_time(self, delta: float) -> float:
        """Seconds the boom has to rise while the swing turns ``delta`` [rad] (to the truck's near edge)."""
        ...

    def boom_rate(self) -> float:
        """The boom's rising speed [rad/s]."""
        ...

    def open_lead(self, bucket_delta: float, tol: float) -> float:
        """How far before the dump angle [rad] the bucket starts to open, for an opening of ``bucket_delta``
        [rad] (``tol`` [rad]: a joint error that counts as arrived)."""
        ...


@dataclasses.dataclass(frozen=True)
class TimingModel:
    """The simplified machine model of §4.2: how long a joint takes to move from A to B.

    Each joint moves at its flow-limited speed ``speed`` [rad/s] until its error falls to
    ``speed / gain`` and then closes the error exponentially at ``gain`` [1/s] (the servo law of
    :func:`excavsim.robot.servo.setpoint_rates`), after a ``latency`` [s] (assumed: the thesis names
    velocities and latencies without numbers). ``speed`` is keyed by the joints' roles in the script
    (``swing``, ``boom``, ``stick``, ``bucket``) or any names :meth:`time_to` is asked about.
    """

    speed: dict[str, float]
    gain: float
    latency: float = 0.1

    def time_to(self, joint: str, delta: float, tol: float) -> float:
        """Seconds for ``joint`` to come within ``tol`` [rad] of a target ``delta`` [rad] away."""
        v, k, d = self.speed[joint], self.gain, abs(delta)
        if d <= tol:
            return self.latency
        knee = v / k
        if d > knee:
            return self.latency + (d - knee) / v + math.log(knee / tol) / k
        return self.latency + math.log(d / tol) / k

    def travel_time(self, joint: str, delta: float) -> float:
        """Seconds for ``joint`` to cover ``delta`` [rad] at full speed (a move towards a farther target)."""
        return self.latency + abs(delta) / self.speed[joint]

    def remaining(self, joint: str, seconds: float, tol: float) -> float:
        """How far from its target [rad] ``joint`` still is ``seconds`` before it comes within ``tol``."""
        v, k = self.speed[joint], self.gain
        knee = v / k
        t_knee = math.log(knee / tol) / k
        if seconds <= t_knee:
            return tol * math.exp(k * seconds)
        return knee + v * (seconds - t_knee)

    def swing_time(self, delta: float) -> float:
        """The swing's travel at full speed, its latency not counted (the boom starts as the swing does)."""
        return max(self.travel_time("swing", delta) - self.latency, 0.0)

    def boom_rate(self) -> float:
        return self.speed["boom"]

    def open_lead(self, bucket_delta: float, tol: float) -> float:
        """The bucket opens so that it is half open as the swing arrives: the swing's remaining angle when
        the bucket's time to half open is left."""
        t_half = self.time_to("bucket", 0.5 * bucket_delta, tol)
        return self.remaining("swing", t_half, tol)


@dataclasses.dataclass(frozen=True)
class SwingProfile:
    """The swing's set-point profile (module docstring): acceleration ``accel`` [rad/s^2] and top speed
    ``speed`` [rad/s] (assumed, below the machine's relief torque over its inertia and its flow limit); the
    set-point never runs more than ``lead`` [rad] ahead of the swing (assumed)."""

    accel: float = 0.22
    speed: float = 1.0
    lead: float = 0.08

    def time_to_cover(self, travel: float) -> float:
        """Seconds the profile takes to cover ``travel`` [rad] from rest (a triangle or a trapezoid)."""
        travel = abs(travel)
        if travel < self.speed ** 2 / self.accel:
            return 2.0 * math.sqrt(travel / self.accel)
        return travel / self.speed + self.speed / self.accel


class SwingTracker:
    """The swing's set-point moving along a :class:`SwingProfile` towards each command, from ``start`` [rad]."""

    def __init__(self, profile: SwingProfile, start: float):
        self.p, self.pos, self.vel = profile, float(start), 0.0

    def next(self, target: float, dt: float, actual: float | None = None) -> float:
        """The set-point [rad] one control period ``dt`` [s] later, towards ``target`` [rad], the swing at
        ``actual`` [rad] (None: not held to the swing)."""
        e = target - self.pos
        want = math.copysign(min(self.p.speed, math.sqrt(2.0 * self.p.accel * abs(e))), e)
        dv = float(np.clip(want - self.vel, -self.p.accel * dt, self.p.accel * dt))
        self.vel += dv
        self.pos += self.vel * dt
        if actual is not None and abs(self.pos - actual) > self.p.lead:
            # the swing lags (its torque saturated): hold the set-point ``lead`` ahead and the profile's speed
            # at the swing's, so that the deceleration starts from the speed the swing really has
            self.pos = actual + math.copysign(self.p.lead, self.pos - actual)
            self.vel = math.copysign(min(abs(self.vel), abs(self.vel) - self.p.accel * dt), self.vel) \
                if abs(self.vel) > self.p.accel * dt else self.vel
        if (target - self.pos) * e <= 0:  # passed it: hold the target
            self.pos, self.vel = target, 0.0
        return self.pos


@dataclasses.dataclass(frozen=True)
class ProfileTiming:
    """The 25 t's machine model: the swing along ``profile``, the boom rising at ``boom_speed`` [rad/s] (the
    cylinder's flow limit over its moment arm), the bucket opening ``lead`` [rad] before the dump angle (a
    "magic number" of §4.2, assumed)."""

    profile: SwingProfile
    boom_speed: float
    lead: float = math.radians(6.0)

    def swing_time(self, delta: float) -> float:
        """The profile's time over ``delta`` [rad]."""
        return self.profile.time_to_cover(delta)

    def boom_rate(self) -> float:
        return self.boom_speed

    def open_lead(self, bucket_delta: float, tol: float) -> float:
        return self.lead
