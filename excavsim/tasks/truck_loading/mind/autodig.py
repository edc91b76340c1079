"""AutoDig: the 25 t excavator's dig of one bucket load, ended by angles and cylinder pressures (Rowe 1997 §4.4).

The dig as steps whose transitions are angles reached and **cylinder pressures exceeding thresholds**,
not a fixed path:

* Penetrate: the tip goes down into the face until it is ``depth_m`` below the scanned surface or the
  boom cylinder's pressure passes ``penetrate_pa`` (resistance).
* Drag: the tip is pulled towards the machine along the scanned surface at that depth; its speed is a
  look-up of the stick cylinder's pressure (full speed below ``slow_pa``, a quarter at the relief
  pressure: §4.4's "cylinder velocity commands ... a function of the measured cylinder pressures", the
  table assumed) and the tip rises while the pressure is above ``rise_pa``; the drag ends when the
  stick's pressure has stayed above ``full_pa`` for ``full_s`` with the tip risen to within
  ``full_depth_m`` of the surface (the bucket is full and pushes a heap: the dig **ends on resistance**)
  or after ``drag_m`` of drag.
* Curl: the bucket closes to its capture angle while the tip rises, until the bucket angle passes it.

Rowe's script (:mod:`excavsim.execution.rowe_script`) then carries the load to the truck. Everything here
reads sensor-level data (joint angles, cylinder pressures, time) through
:class:`~excavsim.handoff.observation.HydraulicServos` (the world's
:class:`~excavsim.tasks.truck_loading.world.truck.TruckWorld` is one) and the robot's own kinematics;
nothing reads the world's truth.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from excavsim.handoff.observation import HydraulicServos
from excavsim.robot.kinematics import PlanarArm


@dataclasses.dataclass(frozen=True)
class AutoDigConfig:
    """AutoDig's thresholds and speeds (Rowe 1997 §4.4; every number assumed, configs/truck_loading.yaml).

    Attributes:
        depth_m: the cut's depth below the scanned surface [m]; drag_m: the longest drag [m].
        penetrate_speed_m_s, drag_speed_m_s, rise_speed_m_s: tip speeds [m/s].
        penetrate_pa: boom pressure that ends the penetration [Pa]; slow_pa, rise_pa: stick pressures above
            which the drag slows and the tip rises [Pa]; full_pa held ``full_s`` [s] with the cut no deeper
            than ``full_depth_m`` [m] (the tip has risen out of the cut and still meets resistance): the bucket
            is full and pushes its heap.
        relief_pa: the relief pressure (the drag's look-up table ends there) [Pa].
        attack_deg: the tip's pitch while it penetrates and drags (the blade raked towards the machine) [deg].
        capture_deg: the tip's pitch once curled, the mouth up [deg]; curl_lift_m: the rise while curling [m];
            curl_rate_rad_s: the pitch's rate while curling [rad/s].
        filter_s: the pressures' low-pass time constant [s] (:class:`_Filtered`).
        timeout_s: the longest dig [s].
    """

    depth_m: float = 0.5
    drag_m: float = 3.0
    penetrate_speed_m_s: float = 0.6
    drag_speed_m_s: float = 0.8
    rise_speed_m_s: float = 0.4
    penetrate_pa: float = 20e6
    slow_pa: float = 15e6
    rise_pa: float = 26e6
    full_pa: float = 28e6
    full_s: float = 0.4
    full_depth_m: float = 0.1
    relief_pa: float = 34.3e6
    attack_deg: float = 35.0
    capture_deg: float = -40.0
    curl_lift_m: float = 0.6
    curl_rate_rad_s: float = 1.2
    filter_s: float = 0.3
    timeout_s: float = 30.0


@dataclasses.dataclass
class DigRun:
    """What AutoDig did: its duration [s], why each phase ended, the drag's length [m], the peak pressures
    (boom, stick, bucket) [Pa], and the joint angles at its end (4,) [rad]."""

    duration_s: float
    penetrate_end: str
    drag_end: str
    drag_m: float
    peak_pa: np.ndarray
    q_end: np.ndarray
    phases: list[tuple[float, str]] = dataclasses.field(default_factory=list)
    trace: np.ndarray | None = None  # (n, 4): time [s] and the filtered boom, stick, bucket pressures [Pa]


def _to(arm: PlanarArm, pose, q_prev: np.ndarray) -> np.ndarray:
    q, ok = arm.inverse(np.asarray(pose, float))
    if not ok:
        return q_prev
    return np.clip(q, np.asarray(arm.lower), np.asarray(arm.upper))


class _Filtered:
    """The cylinder pressures low-passed (first order, ``tau`` [s]): the servo valves' and the soil's chatter
    makes the raw readings swing by tens of MPa from one control step to the next (measured), so thresholds
    act on the filtered pressure, as a real controller's would (assumed time constant)."""

    def __init__(self, machine: HydraulicServos, tau: float):
        self.machine, self.k = machine, min(1.0, machine.control_dt / tau)
        self.value = np.asarray(machine.cylinder_pressures(), float)

    def update(self) -> np.ndarray:
        self.value = self.value + self.k * (np.asarray(self.machine.cylinder_pressures(), float) - self.value)
        return self.value


def autodig(machine: HydraulicServos, arm: PlanarArm, swing: float, start_r: float, surface, cfg: AutoDigConfig, *,
            min_r: float = 4.0) -> DigRun:
    """Dig one bucket load at swing angle ``swing`` [rad] from radius ``start_r`` [m] towards the machine
    (module docstring). ``surface(r)`` is the scanned ground's height [m] at radius ``r`` along the dig's line
    (the mind's map). The bucket starts above the face, at the pose Rowe's script left it. Pressures are
    compared by magnitude (the boom pushes down, the stick pulls in) after :class:`_Filtered`."""
    dt = machine.control_dt
    t = 0.0
    q = machine.joint_angles()
    attack = math.radians(cfg.attack_deg)
    peak = np.zeros(3)
    phases: list[tuple[float, str]] = []
    trace: list[tuple[float, float, float, float]] = []
    filt = _Filtered(machine, cfg.filter_s)
    # penetrate: down along the blade's direction from above the surface at start_r
    x, z = start_r, float(surface(start_r)) + 0.3
    z_goal = float(surface(start_r)) - cfg.depth_m
    why_pen = "depth"
    while z > z_goal:
        p = np.abs(filt.update())
        peak = np.maximum(peak, p)
        trace.append((t, *p))
        if p[0] > cfg.penetrate_pa and z < float(surface(x)):
            why_pen = "boom pressure"
            break
        z -= cfg.penetrate_speed_m_s * dt
        x -= 0.3 * cfg.penetrate_speed_m_s * dt
        q = np.r_[swing, _to(arm, (x, z, attack), q[1:])]
        machine.step(q)
        t += dt
        if t > cfg.timeout_s:
            why_pen = "timeout"
            break
    phases.append((t, f"penetrate ended: {why_pen}"))
    depth = max(float(surface(x)) - z, 0.05)
    x0, held, why_drag = x, 0.0, "length"
    while True:
        p = np.abs(filt.update())
        peak = np.maximum(peak, p)
        trace.append((t, *p))
        ps = p[1]
        # full: the pressure stays high although the tip has risen to the surface (the bucket pushes its heap)
        held = held + dt if ps > cfg.full_pa and depth <= cfg.full_depth_m else 0.0
        if held >= cfg.full_s:
            why_drag = "stick pressure (full)"
            break
        if x0 - x >= cfg.drag_m or x <= min_r:
            break
        if t > cfg.timeout_s:
            why_drag = "timeout"
            break
        # §4.4: the speed a function of the pressure (a linear table from slow_pa to the relief: full to 1/4)
        share = 1.0 - 0.75 * float(np.clip((ps - cfg.slow_pa) / (cfg.relief_pa - cfg.slow_pa), 0.0, 1.0))
        x -= cfg.drag_speed_m_s * share * dt
        if ps > cfg.rise_pa:
            depth = max(depth - cfg.rise_speed_m_s * dt, 0.0)
        z = float(surface(x)) - depth
        q = np.r_[swing, _to(arm, (x, z, attack), q[1:])]
        machine.step(q)
        t += dt
    phases.append((t, f"drag ended: {why_drag}"))
    # curl: the bucket closes to the capture pitch while the tip rises
    pose0 = np.array([x, z, attack])
    capture = math.radians(cfg.capture_deg)
    n = max(1, int(math.ceil(max(abs(capture - attack) / cfg.curl_rate_rad_s, cfg.curl_lift_m / cfg.rise_speed_m_s)
                             / dt)))
    for k in range(1, n + 1):
        f = k / n
        pose = pose0 + f * np.array([0.0, cfg.curl_lift_m, capture - attack])
        q = np.r_[swing, _to(arm, pose, q[1:])]
        machine.step(q)
        t += dt
        p = np.abs(filt.update())
        peak = np.maximum(peak, p)
        trace.append((t, *p))
    # until the bucket's angle has passed the capture angle's (the last transition on an angle, §4.4)
    for _ in range(int(3.0 / dt)):
        qa = machine.joint_angles()
        if qa[3] <= q[3] + math.radians(5.0):
            break
        machine.step(q)
        t += dt
    phases.append((t, "curl ended"))
    return DigRun(t, why_pen, why_drag, float(x0 - x), peak, machine.joint_angles(), phases, np.array(trace))
