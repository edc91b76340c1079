"""Rowe's truck-loading cycle on a hydraulic excavator: AutoDig, the coupled script, the swing's profile.

One **pass** (one bucket load) is two scripts, as in Rowe 1997 §4.3-4.4:

* :func:`autodig` (§4.4, AutoDig): the dig as steps whose transitions are angles reached and **cylinder
  pressures exceeding thresholds**, not a fixed path. Penetrate: the tip goes down into the face until it
  is ``depth_m`` below the scanned surface or the boom cylinder's pressure passes ``penetrate_pa``
  (resistance). Drag: the tip is pulled towards the machine along the scanned surface at that depth; its
  speed is a look-up of the stick cylinder's pressure (full speed below ``slow_pa``, a quarter at the
  relief pressure: §4.4's "cylinder velocity commands ... a function of the measured cylinder pressures",
  the table assumed) and the tip rises while the pressure is above ``rise_pa``; the drag ends when the
  stick's pressure has stayed above ``full_pa`` for ``full_s`` with the tip risen to within
  ``full_depth_m`` of the surface (the bucket is full and pushes a heap: the dig **ends on resistance**)
  or after ``drag_m`` of drag. Curl: the bucket closes to its capture angle
  while the tip rises, until the bucket angle passes it.
* :func:`loading_script` (§4.3, Fig. 4 on this machine): four single-joint sub-scripts, coupled through
  conditions on the other joints. Swing: wait; **when the boom passes ``boom_trigger``, swing to the
  truck**; when the bucket is ``return_fraction`` open, swing back to the dig; stop there. Boom: raise to
  ``boom_carry``; at the truck lower to ``boom_dump``; back past ``swing_back``, lower to the next dig.
  Stick: wait; out to ``stick_dump`` at ``stick_fraction`` of the swing; in again on the way back.
  Bucket: capture; open at the truck (swing within ``open_lead`` of the dump angle); to the dig on the way back.

The parameters (:func:`compute_params`, §4.2): the dump pose by inverse kinematics so that the open
bucket's pour point (its lowest point) is over the dump point chosen in the truck, with the bucket's
lowest point ``clearance_m`` above the truck's side; the boom's **clearance angle** over the truck's
side (Fig. 3, :func:`clearance_boom_angle`, a closed form from the link lengths and the side's height);
and the **boom trigger** from a machine model of the timing (Fig. 4, §4.2: the swing may start before the
boom is clear, timed so the boom passes the clearance angle when the swing reaches the truck's near edge).

The swing of a 25 t machine is torque-limited (its relief torque over the upper structure's inertia
gives about 0.3 rad/s^2), so a step command overshoots by half a radian (``excavsim.world.hydraulics``
has no deceleration valve). :class:`SwingProfile` is the controller's answer (assumed, as an operator
eases off): the swing's set-point follows a trapezoidal profile of ``accel`` and ``speed`` towards the
script's command; the other joints get the script's commands as steps, as Rowe's PD controller did (§4.0).

Everything here reads sensor-level data (joint angles, cylinder pressures, time) through a
:class:`ExcavatorServos` (the world's :class:`~excavsim.world.truck.TruckWorld` is one) and the robot's own
kinematics; nothing reads the world's truth.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Protocol

import numpy as np

from excavsim.errors import GoalError
from excavsim.execution.conditions import Sense, all_of, always, joint_above, joint_below, started
from excavsim.execution.script import Command, Script, ScriptEngine, Step, SubScript
from excavsim.robot.excavators import CHAIN_JOINTS
from excavsim.robot.kinematics import PlanarArm

SWING, BOOM, STICK, BUCKET = CHAIN_JOINTS


class ExcavatorServos(Protocol):
    """What the excavator's executor reads and commands (sensor level)."""

    control_dt: float

    def step(self, target: np.ndarray) -> np.ndarray:
        """One control step towards joint targets (4,) [rad]; the joint angles after it."""

    def joint_angles(self) -> np.ndarray:
        """The joint encoders (4,) [rad]."""

    def cylinder_pressures(self) -> np.ndarray:
        """The boom, stick and bucket cylinders' pressures (3,) [Pa]."""


def clearance_boom_angle(arm: PlanarArm, stick: float, bucket: float, height_m: float, clearance_m: float, *,
                         outline: bool = True) -> float:
    """Rowe 1997 Fig. 3: the lowest boom angle [rad] at which the bucket clears a truck side ``height_m``
    [m, above the ground] by ``clearance_m``, with the stick and bucket at ``stick`` and ``bucket`` [rad].

    Closed form: with the stick and bucket held, every point ``p`` of the bucket (its outline, or only the
    tip when ``outline`` is False) turns rigidly about the boom's foot ``f`` as the boom turns, so its height
    is ``z_f + A sin(theta + psi)`` with ``A e^(i psi)`` the point's offset from the foot at boom angle
    zero (for the tip, ``A e^(i psi) = l1 + l2 e^(i q2) + l3 e^(i (q2 + q3 + blade))``, the link lengths);
    the point is at ``h + c`` where ``theta = asin((h + c - z_f) / A) - psi`` (the rising branch). The boom
    angle is the largest over the points.

    Raises:
        GoalError: some point cannot reach that height (``A`` too short) or the angle is above the boom's limit.
    """
    pose = arm.forward(np.array([0.0, stick, bucket]))
    pts = arm.bucket_points(pose) if outline else pose[None, :2]
    rel = np.asarray(pts, float) - np.asarray(arm.shoulder_xz, float)
    a = np.hypot(rel[:, 0], rel[:, 1])
    psi = np.arctan2(rel[:, 1], rel[:, 0])
    s = (height_m + clearance_m - arm.shoulder_xz[1]) / a
    if np.any(np.abs(s) > 1.0):
        raise GoalError(f"the bucket cannot clear {height_m + clearance_m:.2f} m with the stick at "
                        f"{math.degrees(stick):.0f} deg and the bucket at {math.degrees(bucket):.0f} deg")
    theta = float(np.max((np.arcsin(s) - psi) / arm.joint_signs[0]))
    if theta > arm.upper[0]:
        raise GoalError(f"the boom would have to rise to {math.degrees(theta):.1f} deg to clear the truck, "
                        f"above its limit of {math.degrees(arm.upper[0]):.1f} deg")
    return theta


def bucket_for_pitch(arm: PlanarArm, boom: float, stick: float, pitch: float) -> float:
    """The bucket angle [rad] that puts the tip at ``pitch`` [rad] with the boom and stick at ``boom``, ``stick``."""
    p0 = float(arm.forward(np.array([boom, stick, 0.0]))[2])
    return float((pitch - p0 + math.pi) % (2.0 * math.pi) - math.pi) / float(arm.joint_signs[2])


def dump_pose(arm: PlanarArm, site: LoadSite, dump_r: float, bucket_carry: float, *, pour_pitch_deg: float = 63.0,
              open_pitch_deg: float = 105.0) -> tuple[float, float, float]:
    """(boom, stick, bucket open) [rad] of the dump: the tip at radius ``dump_r`` [m] when the opening bucket
    is at the pour's pitch (the soil leaves over the tip there), and the whole arc the bucket sweeps while it
    opens from ``bucket_carry`` at least ``site.clearance_m`` above the truck's side (Fig. 3 for the dump).
    A search over the stick's angle: for each, the boom is the arc's clearance angle; the stick whose pour
    point lands nearest ``dump_r`` wins.

    Raises:
        GoalError: no stick angle puts the pour within 0.5 m of ``dump_r`` with the boom within its limits.
    """
    pour, opened = math.radians(pour_pitch_deg), math.radians(open_pitch_deg)
    best = None
    for stick in np.linspace(arm.lower[1] + 0.05, arm.upper[1] - 0.05, 60):
        boom = float(arm.lower[0])
        try:
            for _ in range(2):  # the open angle depends on the boom
                b_open = bucket_for_pitch(arm, boom, stick, opened)
                arc = np.linspace(bucket_carry, min(b_open, float(arm.upper[2])), 12)
                boom = max(clearance_boom_angle(arm, float(stick), float(b), site.side_z_m, site.clearance_m)
                           for b in arc)
        except GoalError:
            continue
        b_pour = bucket_for_pitch(arm, boom, stick, pour)
        r = float(arm.forward(np.array([boom, stick, b_pour]))[0])
        if best is None or abs(r - dump_r) < best[0]:
            best = (abs(r - dump_r), boom, float(stick), min(b_open, float(arm.upper[2])))
    if best is None or best[0] > 0.5:
        raise GoalError(f"no dump pose pours at r = {dump_r:.2f} m with the bucket clear of the truck's side "
                        f"({site.side_z_m + site.clearance_m:.2f} m)")
    return best[1], best[2], best[3]


def pitch_offset(arm: PlanarArm, pitch: float) -> np.ndarray:
    """The bucket's lowest point relative to the tip (x, z) [m] at tip ``pitch`` [rad]: where soil leaves it."""
    pts = arm.bucket_points(np.array([0.0, 0.0, pitch]))
    return pts[int(np.argmin(pts[:, 1]))]


@dataclasses.dataclass(frozen=True)
class SwingProfile:
    """The swing's set-point profile (module docstring): acceleration ``accel`` [rad/s^2] and top speed
    ``speed`` [rad/s] (assumed, below the machine's relief torque over its inertia and its flow limit); the
    set-point never runs more than ``lead`` [rad] ahead of the swing (assumed)."""

    accel: float = 0.22
    speed: float = 1.0
    lead: float = 0.08


class _SwingTracker:
    def __init__(self, profile: SwingProfile, start: float):
        self.p, self.pos, self.vel = profile, float(start), 0.0

    def next(self, target: float, dt: float, actual: float | None = None) -> float:
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


# -- AutoDig -------------------------------------------------------------------------------------------------
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

    def __init__(self, machine: ExcavatorServos, tau: float):
        self.machine, self.k = machine, min(1.0, machine.control_dt / tau)
        self.value = np.asarray(machine.cylinder_pressures(), float)

    def update(self) -> np.ndarray:
        self.value = self.value + self.k * (np.asarray(self.machine.cylinder_pressures(), float) - self.value)
        return self.value


def autodig(machine: ExcavatorServos, arm: PlanarArm, swing: float, start_r: float, surface, cfg: AutoDigConfig, *,
            min_r: float = 4.0) -> DigRun:
    """Dig one bucket load at swing angle ``swing`` [rad] from radius ``start_r`` [m] towards the machine
    (module docstring). ``surface(r)`` is the scanned ground's height [m] at radius ``r`` along the dig's line
    (the mind's map). The bucket starts above the face, at the pose the loading script left it. Pressures are
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


def approach(machine: ExcavatorServos, target: np.ndarray, profile: SwingProfile, *, tol: float = 0.03,
             timeout_s: float = 20.0) -> float:
    """Move to joint angles ``target`` (4,) [rad] (the swing through ``profile``) until every joint is within
    ``tol`` [rad]; returns the time it took [s]."""
    q = machine.joint_angles()
    tracker = _SwingTracker(profile, q[0])
    dt, t = machine.control_dt, 0.0
    target = np.asarray(target, float)
    while t < timeout_s and np.max(np.abs(q - target)) > tol:
        cmd = target.copy()
        cmd[0] = tracker.next(target[0], dt, float(q[0]))
        q = machine.step(cmd)
        t += dt
    return t


# -- the loading script ---------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class LoadSite:
    """The truck as the mind knows it: its sides' height [m above the ground], the clearance the bucket
    keeps above them [m], and the swing angle at which the swing reaches the bed's near edge [rad]."""

    side_z_m: float
    clearance_m: float
    edge_swing: float


#: The parameters tuned online (Rowe 1997 §6.2; which ones here is assumed), in the learner's order:
#: the swing profile's acceleration [rad/s^2] (how hard the machine may swing: faster, or overshooting the
#: truck, §1's "understanding of the machine's own performance abilities"), the dump's radial and swing
#: offsets [m, rad] (added to the aim computed from the scanned fill) and the bucket's opening share that
#: sends the swing back.
TUNED = ("swing_accel", "aim_dr", "aim_dtheta", "return_fraction")


@dataclasses.dataclass(frozen=True)
class LoadParams:
    """Every number of the loading script (angles [rad]); see the module docstring."""

    swing_dig: float
    swing_dump: float
    swing_back: float
    stick_fraction: float
    open_lead: float
    boom_trigger: float
    boom_clear: float
    boom_carry: float
    boom_dump: float
    stick_carry: float
    stick_dump: float
    bucket_carry: float
    bucket_open: float
    return_fraction: float
    q_next: tuple[float, float, float]
    stop_tol: float = math.radians(3.0)
    timeout_s: float = 40.0


def compute_params(arm: PlanarArm, site: LoadSite, dig_end: np.ndarray, swing_dig: float, dump_r: float,
                   dump_theta: float, q_next: np.ndarray, *, boom_speed: float, swing: SwingProfile,
                   trigger_lead: float = 0.0, return_fraction: float = 0.8, pour_pitch_deg: float = 63.0,
                   open_pitch_deg: float = 105.0, safety: float = 0.8) -> LoadParams:
    """The script's parameters for one pass (§4.2): the dump pose by inverse kinematics, the boom's
    clearance angle over the side (Fig. 3), and the boom trigger from the timing model (Fig. 4).

    Args:
        arm: the robot's planar kinematics.
        site: the truck.
        dig_end: (4,) the joint angles when digging finished [rad].
        swing_dig: the dig's swing angle [rad]; dump_r, dump_theta: the dump point in the truck [m, rad].
        q_next: (3,) boom, stick, bucket [rad] of the next dig's start (the return pose).
        boom_speed: the boom's speed [rad/s] (the machine model: the cylinder's flow limit over its moment arm).
        swing: the swing's profile (its time to the truck's edge).
        trigger_lead: how much earlier than the timing model's trigger the swing starts [rad] (tuned).
        return_fraction: the bucket's opening share that sends the swing back (tuned).
        pour_pitch_deg, open_pitch_deg: the tip's pitch in the middle of the pour and with the bucket open
            (the world's bucket pours between about 43 and 83 deg of this machine's pitch; "magic numbers"
            of §4.2, assumed).
        safety: the share of the swing's time the boom is given to clear (assumed).

    Raises:
        GoalError: the dump pose is out of reach or the bucket cannot clear the side.
    """
    # the encoders may read a hair past a limit (the joint's soft limit): the commands stay within them
    boom0, stick0, bucket0 = (float(v) for v in np.clip(dig_end[1:4], arm.lower, arm.upper))
    stick_carry, bucket_carry = stick0, bucket0
    boom_dump, stick_dump, bucket_open = dump_pose(arm, site, dump_r, bucket_carry, pour_pitch_deg=pour_pitch_deg,
                                                   open_pitch_deg=open_pitch_deg)
    # the carry's stick: of the angles from where the dig left it to the dump's, the one that lets the bucket
    # clear the truck's side with the lowest boom (a dig that ended with the stick tucked in hangs the bucket
    # low: carried so, it needed the boom within 2 deg of its limit and hit the side when the boom lagged);
    # ties keep the stick nearer the dig's (assumed rule)
    best = None
    for stick in np.linspace(stick0, stick_dump, 6):
        try:
            c = clearance_boom_angle(arm, float(stick), bucket_carry, site.side_z_m, site.clearance_m)
        except GoalError:
            continue
        if best is None or c < best[0] - 1e-3:
            best = (c, float(stick))
    if best is None:
        raise GoalError(f"the bucket cannot be carried over the truck's side ({site.side_z_m:.2f} m) from the "
                        f"dig's end pose {np.round(dig_end, 3).tolist()}")
    clear, stick_carry = best
    clear_dump = clearance_boom_angle(arm, stick_dump, bucket_carry, site.side_z_m, site.clearance_m)
    boom_carry = min(max(clear, clear_dump, boom_dump), float(arm.upper[0]))
    # Fig. 4's trigger: the swing reaches the bed's edge after t_swing (the profile's time); the boom, rising
    # at boom_speed, must pass the clearance angle by then, so the swing may start that much below it
    travel = abs(site.edge_swing - swing_dig)
    t_swing = 2.0 * math.sqrt(travel / swing.accel) if travel < swing.speed ** 2 / swing.accel else \
        travel / swing.speed + swing.speed / swing.accel
    trigger = clear - safety * boom_speed * t_swing - trigger_lead
    boom_trigger = float(np.clip(trigger, boom0 + 0.01, clear))
    swing_back = swing_dig + 0.6 * (dump_theta - swing_dig)
    return LoadParams(swing_dig=swing_dig, swing_dump=dump_theta, swing_back=swing_back, stick_fraction=0.4,
                      open_lead=math.radians(6.0), boom_trigger=boom_trigger, boom_clear=clear, boom_carry=boom_carry,
                      boom_dump=boom_dump, stick_carry=stick_carry, stick_dump=stick_dump, bucket_carry=bucket_carry,
                      bucket_open=bucket_open, return_fraction=float(return_fraction),
                      q_next=tuple(float(v) for v in np.clip(q_next, arm.lower, arm.upper)))


def loading_script(p: LoadParams) -> Script:
    """Rowe 1997 Fig. 4 on the excavator with the parameters ``p`` (module docstring)."""

    def go(t: float) -> Command:
        return Command((float(t),))

    sign = 1.0 if p.swing_dump >= p.swing_dig else -1.0
    near_dump = (joint_above(SWING, p.swing_dump - p.open_lead) if sign > 0
                 else joint_below(SWING, p.swing_dump + p.open_lead))
    stick_out = (joint_above(SWING, p.swing_dig + p.stick_fraction * (p.swing_dump - p.swing_dig)) if sign > 0
                 else joint_below(SWING, p.swing_dig + p.stick_fraction * (p.swing_dump - p.swing_dig)))
    opened = p.bucket_carry + p.return_fraction * (p.bucket_open - p.bucket_carry)
    back = all_of(started("swing to dig"), joint_below(SWING, p.swing_back) if sign > 0
                  else joint_above(SWING, p.swing_back))
    arrived = (joint_below(SWING, p.swing_dig + p.stop_tol) if sign > 0 else joint_above(SWING, p.swing_dig - p.stop_tol))
    swing = SubScript((SWING,), (
        Step("swing wait", always(), go(p.swing_dig)),
        Step("swing to truck", joint_above(BOOM, p.boom_trigger), go(p.swing_dump)),
        Step("swing to dig", all_of(started("open bucket"), joint_above(BUCKET, opened)), go(p.swing_dig)),
        Step("stop to dig", all_of(started("swing to dig"), arrived), go(p.swing_dig), ends=always())))
    boom = SubScript((BOOM,), (
        Step("raise boom", always(), go(p.boom_carry)),
        Step("boom dump", near_dump, go(p.boom_dump)),
        Step("lower boom", back, go(p.q_next[0]))))
    stick = SubScript((STICK,), (
        Step("stick wait", always(), go(p.stick_carry)),
        Step("stick out", stick_out, go(p.stick_dump)),
        Step("stick to dig", back, go(p.q_next[1]))))
    bucket = SubScript((BUCKET,), (
        Step("capture", always(), go(p.bucket_carry)),
        Step("open bucket", near_dump, go(p.bucket_open)),
        Step("bucket to dig", back, go(p.q_next[2]))))
    return Script("truck loading", (swing, boom, stick, bucket), timeout_s=p.timeout_s)


@dataclasses.dataclass
class ScriptRun:
    """What the loading script did: its duration [s], how it stopped (``end`` or ``timeout``), when each
    step started [s from the start], and the boom's angle when the swing started [rad]."""

    duration_s: float
    outcome: str
    phase_starts: dict[str, float]
    boom_at_swing: float


def run_script(machine: ExcavatorServos, script: Script, profile: SwingProfile) -> ScriptRun:
    """Run ``script`` tick by tick on ``machine``: the swing through ``profile``, the others as steps."""
    engine = ScriptEngine(script)
    q = machine.joint_angles()
    target = q.copy()
    tracker = _SwingTracker(profile, q[0])
    dt, t = machine.control_dt, 0.0
    starts: dict[str, float] = {}
    boom_at_swing = math.nan
    names = list(CHAIN_JOINTS)
    zero = {n: 0.0 for n in names}
    limit = script.timeout_s or math.inf
    last = q.copy()
    while True:
        qdot = {n: float(v) for n, v in zip(names, (q - last) / dt)}
        p = machine.cylinder_pressures()
        torque = {**zero, BOOM: float(p[0]), STICK: float(p[1]), BUCKET: float(p[2])}
        sense = Sense(t, {n: float(v) for n, v in zip(names, q)}, qdot, torque, np.zeros(3))
        commands = engine.tick(sense)
        for sub, cmd in zip(script.subscripts, commands):
            for j, v in zip(sub.joints, cmd.targets):
                target[names.index(j)] = v
        engine.end_tick(sense)
        for tr in engine.transitions:
            if tr.name not in starts:
                starts[tr.name] = tr.time
                if tr.name == "swing to truck":
                    boom_at_swing = float(q[1])
        if engine.stop is not None:
            return ScriptRun(t, engine.stop.kind, starts, boom_at_swing)
        if t > limit + 1.0:
            return ScriptRun(t, "timeout", starts, boom_at_swing)
        cmd = target.copy()
        cmd[0] = tracker.next(target[0], dt, float(q[0]))
        last = q
        q = machine.step(cmd)
        t += dt

