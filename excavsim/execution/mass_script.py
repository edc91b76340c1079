"""The mass-excavation (truck-loading) script of Rowe 1997 §4.3 and §6.2 on the script engine.

After a dig, four single-joint sub-scripts run side by side, coupled through conditions on the
other joints (the listing of §6.2, Fig. 4): swing = waist, boom = shoulder, stick = elbow, bucket =
wrist pitch (positive angles raise the boom, extend the stick and open the bucket, as in the
thesis' listing; wrist yaw and roll stay level)::

    Swing:  1) when digging finishes, wait                        -> swing_dig
            2) when boom > boom_trigger, swing to the truck       -> swing_dump
            3) when bucket > bucket_return, swing to the dig face -> swing_dig
            4) when swing < swing_dig + stop_tol, stop to dig     (ends the script)
    Boom:   1) when digging finishes, raise boom                  -> boom_carry
            2) when swing > swing_dump - open_lead and stick past stick_open, begin dump -> boom_dump
            3) when bucket > bucket_dumped, continue to dump      -> boom_carry
            4) when swing < swing_back, lower boom to dig         -> boom_dig
    Stick:  1) when digging finishes, wait                        -> stick_carry
            2) when swing is stick_fraction of the way to the truck, begin dump procedure -> stick_dump
            3) when bucket > bucket_dumped, continue to dump      -> stick_after
            4) when swing < swing_back, move to dig               -> stick_dig
    Bucket: 1) when digging finishes, capture soil                -> bucket_carry
            2) when swing > swing_dump - open_lead and stick past stick_open, open -> bucket_open
            3) when swing < swing_back, move to dig               -> bucket_dig

The parameters are computed for each load (:func:`compute_params`, §4.2): the joint commands from
the geometry (inverse kinematics to the dump point, the boom's clearance angle over the truck's side
of Fig. 3), and the triggers from a simple machine timing model (:class:`TimingModel`: each joint's
speed limit and the servo's approach, plus a latency): the boom trigger lets the swing start before
the boom is clear, timed so the boom reaches the clearance angle by the time the swing reaches the
truck's side. Seven of them are tuned online (:data:`TUNED`, §6.2): which seven is not legible in
the thesis' listing, so the choice here is **assumed** (the ones that set the time and where the soil
lands). Two of the seven are written as fractions of a motion (``stick_fraction`` of the swing's
travel, ``return_fraction`` of the bucket's opening) so that no tuned value can leave a trigger that
never fires (assumed). The bucket-open lead ``open_lead`` is computed, not tuned: at the computed
parameters the stick's condition of the same rule holds later than the swing's (the stick starts at
``stick_fraction`` of the swing and must be ``stick_open_fraction`` out), so the bucket opens when the
stick is out and ``open_lead`` changed nothing (measured: the same trial for any lead within
+-10 deg); the stick's trigger is the one that sets when the dump begins, and it is tuned instead.

:func:`run_joint_script` runs a script whose commands are all joint targets on any
:class:`~excavsim.handoff.observation.Servos` (the world's Simulation is one), and
:func:`follow_path` drives the tip along a Cartesian path (the fixed dig of §6.2).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from excavsim import constants
from excavsim.errors import GoalError, UsageError
from excavsim.execution.conditions import Cond, Sense, all_of, always, joint_above, joint_below, started
from excavsim.execution.paths import PathFollower
from excavsim.execution.script import Command, Script, ScriptEngine, Step, SubScript, Transition
from excavsim.handoff.observation import Servos
from excavsim.robot.kinematics import PlanarArm

SWING, BOOM, STICK, BUCKET = "waist_joint", "shoulder_joint", "elbow_joint", "wrist_pitch_joint"
WRIST_LEVEL = ("wrist_yaw_joint", "wrist_roll_joint")

#: The seven tuned parameters of §6.2 (assumed choice, see the module docstring), in the order of the
#: learner's input vector; angles [rad] except the :data:`FRACTIONS` [-].
TUNED = ("boom_trigger", "swing_dump", "stick_fraction", "boom_dump", "stick_dump", "bucket_open", "return_fraction")
#: The tuned parameters that are fractions of a motion [-] (the others are angles [rad]).
FRACTIONS = ("stick_fraction", "return_fraction")


@dataclasses.dataclass(frozen=True)
class MassParams:
    """Every number of the mass-excavation script (angles [rad]); see the module docstring."""

    swing_dig: float
    swing_dump: float
    stick_fraction: float
    swing_back: float
    stop_tol: float
    open_lead: float
    boom_trigger: float
    boom_carry: float
    boom_dump: float
    boom_dig: float
    stick_carry: float
    stick_dump: float
    stick_after: float
    stick_dig: float
    stick_open_fraction: float
    bucket_carry: float
    bucket_open: float
    bucket_dig: float
    return_fraction: float
    dumped_fraction: float
    timeout_s: float = 40.0
    #: the boom's clearance angle over the truck's side at the dump pose (Fig. 3): the lowest safe boom_dump
    boom_clear_dump: float = -math.inf

    def tuned(self) -> np.ndarray:
        """The seven tuned parameters as a vector, in :data:`TUNED` order."""
        return np.array([getattr(self, n) for n in TUNED], dtype=float)

    def with_tuned(self, x: Sequence[float]) -> MassParams:
        """These parameters with the seven tuned ones replaced by ``x`` (in :data:`TUNED` order)."""
        return dataclasses.replace(self, **{n: float(v) for n, v in zip(TUNED, x)})

    def degrees(self) -> dict[str, float]:
        """Every parameter, angles in degrees (fractions and the timeout as they are), for logs."""
        plain = ("stick_fraction", "return_fraction", "dumped_fraction", "stick_open_fraction", "timeout_s")
        return {f.name: (getattr(self, f.name) if f.name in plain else math.degrees(getattr(self, f.name)))
                for f in dataclasses.fields(self) if f.name != "boom_clear_dump" or math.isfinite(self.boom_clear_dump)}


@dataclasses.dataclass(frozen=True)
class TimingModel:
    """The simplified machine model of §4.2: how long a joint takes to move from A to B.

    Each joint moves at its flow-limited speed ``speed`` [rad/s] until its error falls to
    ``speed / gain`` and then closes the error exponentially at ``gain`` [1/s] (the servo law of
    :func:`excavsim.robot.servo.setpoint_rates`), after a ``latency`` [s] (assumed: the thesis names
    velocities and latencies without numbers).
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


@dataclasses.dataclass(frozen=True)
class TruckSite:
    """Where the load goes: the dump target in polar coordinates about the swing axis (Fig. 11) and
    the truck's side the bucket must clear (Fig. 3).

    Attributes:
        r_d, theta_d: the desired pile position [m, rad].
        side_z: height of the truck's side [m, world z]; with the truck moved away (§6.2) the
            parameters are still computed for it.
        half_width: the truck bed's half-width across the swing direction [m]: the swing reaches
            the truck's side at ``theta_d - half_width / r_d``.
        clearance: margin of the bucket's lowest point above the side [m].
        dump_z: height of the tip at the dump pose [m].
    """

    r_d: float
    theta_d: float
    side_z: float
    half_width: float
    clearance: float
    dump_z: float


def clearance_boom_angle(arm: PlanarArm, stick: float, bucket: float, side_z: float, clearance: float) -> float:
    """Fig. 3: the lowest boom (shoulder) angle [rad] at which, with the stick and bucket at ``stick``
    and ``bucket`` [rad], every point of the bucket is ``clearance`` above ``side_z`` [m]."""

    def lowest(boom: float) -> float:
        pose = arm.forward(np.array([boom, stick, bucket]))
        pts = arm.bucket_points(pose)
        return float(np.min(pts[:, 1]))

    lo, hi = float(arm.lower[0]), float(arm.upper[0])
    if lowest(hi) < side_z + clearance:
        raise GoalError(f"the bucket cannot clear a truck side at {side_z:.2f} m with the stick at "
                        f"{math.degrees(stick):.0f} deg")
    # the bucket rises with the boom over the range used here: bisect for the first clear angle
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if lowest(mid) >= side_z + clearance:
            hi = mid
        else:
            lo = mid
    return hi


def pour_offset(arm: PlanarArm, pitch: float) -> float:
    """How far beyond the tip (along the arm plane's x) the bucket's lowest point is at ``pitch`` [m]:
    where the soil leaves the bucket relative to the tip."""
    pts = arm.bucket_points(np.array([0.0, 0.0, pitch]))
    return float(pts[int(np.argmin(pts[:, 1])), 0])


def compute_params(arm: PlanarArm, site: TruckSite, timing: TimingModel, dig_end: np.ndarray, swing_dig: float, *,
                   tol: float = 0.01, open_pitch: float = math.radians(100.0), safety: float = 0.8,
                   capture_curl: float = math.radians(10.0)) -> MassParams:
    """The script's parameters for one load (§4.2): geometry for the commands, the timing model for
    the triggers.

    Args:
        arm: the robot's planar kinematics.
        site: the dump target and the truck.
        timing: the machine model.
        dig_end: (3,) boom, stick and bucket angles when digging finishes [rad].
        swing_dig: the swing angle of the dig face [rad].
        tol: a joint error that counts as arrived [rad].
        open_pitch: the tip pitch of the open bucket [rad] (a "magic number" of §4.2: assumed).
        safety: the boom trigger leaves the boom this fraction of the swing's time to clear (assumed).
        capture_curl: how much further than the dig's end the bucket curls to carry the load [rad] (assumed).
    """
    boom0, stick0, bucket0 = (float(v) for v in dig_end)
    # the dump pose: the bucket's pour point over r_d, the tip at dump_z, the bucket open
    x_tip = site.r_d - pour_offset(arm, open_pitch)
    q_dump, ok = arm.inverse(np.array([x_tip, site.dump_z, open_pitch]))
    if not ok:
        raise GoalError(f"the dump pose (tip {x_tip:.2f} m out, {site.dump_z:.2f} m up) is out of reach")
    stick_dump, bucket_open = float(q_dump[1]), float(q_dump[2])
    # carry: the stick stays where the dig left it; the bucket is curled ``capture_curl`` past the dig's
    # end pitch and holds that pitch as the boom rises (the pitch is the sum of the planar joint angles)
    stick_carry = stick0
    carry_pitch = float(arm.forward(np.array(dig_end))[2]) - capture_curl
    boom_carry, bucket_carry = boom0, bucket0
    for _ in range(3):  # the clearance angle depends on the bucket's angle, which holds the pitch at it
        bucket_carry = bucket0 - capture_curl - (boom_carry - boom0)
        clear = clearance_boom_angle(arm, stick_carry, bucket_carry, site.side_z, site.clearance)
        clear_dump = clearance_boom_angle(arm, stick_dump, bucket_carry, site.side_z, site.clearance)
        boom_carry = max(clear, clear_dump, float(q_dump[0]))
    del carry_pitch
    boom_dump = max(float(q_dump[0]), clear_dump)
    # the swing reaches the truck's side this long after it starts; the boom must be clear by then
    swing_dump = site.theta_d
    edge = site.theta_d - site.half_width / site.r_d
    t_swing = timing.travel_time(SWING, edge - swing_dig)
    boom_trigger = clear - safety * timing.speed[BOOM] * max(t_swing - timing.latency, 0.0)
    boom_trigger = float(np.clip(boom_trigger, boom0 + tol, clear))
    # the bucket opens so that it is half open as the swing arrives
    t_half = timing.time_to(BUCKET, 0.5 * (bucket_open - bucket_carry), tol)
    open_lead = timing.remaining(SWING, t_half, tol)
    swing_back = swing_dig + 0.75 * (swing_dump - swing_dig)  # clear of the truck on the way back
    # heuristics ("magic numbers" of §4.2, assumed): the stick goes out halfway through the swing
    # (stick_fraction 0.5); the swing returns when the bucket is 80 % open (return_fraction 0.8)
    return MassParams(swing_dig=swing_dig, swing_dump=swing_dump, stick_fraction=0.5, swing_back=swing_back,
                      stop_tol=math.radians(2.0), open_lead=open_lead, boom_trigger=boom_trigger,
                      boom_carry=boom_carry, boom_dump=boom_dump, boom_dig=boom0, stick_carry=stick_carry,
                      stick_dump=stick_dump, stick_after=stick_carry, stick_dig=stick0, stick_open_fraction=0.7,
                      bucket_carry=bucket_carry, bucket_open=bucket_open, bucket_dig=bucket0, return_fraction=0.8,
                      dumped_fraction=0.6, boom_clear_dump=clear_dump)


def passing(joint: str, start: float, end: float, fraction: float) -> Cond:
    """Holds once ``joint``, moving from ``start`` to ``end`` [rad], is ``fraction`` of the way."""
    at = start + fraction * (end - start)
    return joint_above(joint, at) if end >= start else joint_below(joint, at)


def mass_script(p: MassParams) -> Script:
    """The mass-excavation script of §4.3/§6.2 with the parameters ``p`` (see the module docstring)."""

    def go(*targets: float) -> Command:
        return Command(tuple(float(t) for t in targets))

    open_at = all_of(joint_above(SWING, p.swing_dump - p.open_lead),
                     passing(STICK, p.stick_carry, p.stick_dump, p.stick_open_fraction))
    dumped = passing(BUCKET, p.bucket_carry, p.bucket_open, p.dumped_fraction)
    # back at the dig side: once the swing has started back (an engine event; the thesis' "swing < 60 deg"
    # alone would hold on the way out as well when the bucket opens before the swing passes it)
    back = all_of(started("swing to dig face"), joint_below(SWING, p.swing_back))
    swing = (Step("swing wait", always(), go(p.swing_dig)),
             Step("swing to truck", joint_above(BOOM, p.boom_trigger), go(p.swing_dump)),
             # only once the bucket is opening: the bucket starts the script curled beyond its dig angle
             # only when the dig ends curled, and a learned fraction must not send the swing back unloaded
             Step("swing to dig face", all_of(started("open bucket"),
                                              passing(BUCKET, p.bucket_carry, p.bucket_open, p.return_fraction)),
                  go(p.swing_dig)),
             Step("stop to dig", joint_below(SWING, p.swing_dig + p.stop_tol), go(p.swing_dig), ends=always()))
    boom = (Step("raise boom", always(), go(p.boom_carry)),
            Step("boom dump", open_at, go(p.boom_dump)),
            Step("boom continue", dumped, go(p.boom_carry)),
            Step("lower boom", back, go(p.boom_dig)))
    stick = (Step("stick wait", always(), go(p.stick_carry)),
             Step("stick out", passing(SWING, p.swing_dig, p.swing_dump, p.stick_fraction), go(p.stick_dump)),
             Step("stick continue", dumped, go(p.stick_after)),
             Step("stick to dig", back, go(p.stick_dig)))
    bucket = (Step("capture", always(), go(p.bucket_carry)),
              Step("open bucket", open_at, go(p.bucket_open)),
              Step("bucket to dig", back, go(p.bucket_dig)))
    wrist = (Step("level", always(), go(0.0, 0.0)),)
    subs = (SubScript((SWING,), swing), SubScript((BOOM,), boom), SubScript((STICK,), stick),
            SubScript((BUCKET,), bucket), SubScript(WRIST_LEVEL, wrist))
    return Script("mass excavation", subs, timeout_s=p.timeout_s)


@dataclasses.dataclass
class ScriptRun:
    """What a joint script did: its start and stop time [s], how it stopped ("end" or "timeout"), and
    every step change."""

    start: float
    stop: float
    outcome: str
    transitions: list[Transition]

    @property
    def duration(self) -> float:
        return self.stop - self.start

    def phase_starts(self) -> dict[str, float]:
        """When each step started, relative to the script's start [s]."""
        return {tr.name: tr.time - self.start for tr in self.transitions}


def _sense(servos: Servos, obs) -> Sense:
    names = constants.JOINTS
    return Sense(obs.time, dict(zip(names, obs.q)), dict(zip(names, obs.qdot)),
                 dict(zip(names, obs.actuator_force)), np.asarray(obs.ft_force))


def run_joint_script(servos: Servos, script: Script) -> ScriptRun:
    """Run ``script`` (joint-target commands only) tick by tick on ``servos`` until it ends or times out."""
    for sub in script.subscripts:
        for st in sub.steps:
            if st.command.path:
                raise UsageError(f"run_joint_script: step {st.name!r} follows a path; joint targets only")
    engine = ScriptEngine(script)
    names = list(constants.JOINTS)
    obs = servos.observe()
    target = np.array(obs.q, dtype=float)
    start = obs.time
    limit = script.timeout_s or math.inf
    while True:
        sense = _sense(servos, obs)
        commands = engine.tick(sense)
        for sub, cmd in zip(script.subscripts, commands):
            for j, t in zip(sub.joints, cmd.targets):
                target[names.index(j)] = t
        engine.end_tick(sense)
        if engine.stop is not None:
            return ScriptRun(start, obs.time, engine.stop.kind, list(engine.transitions))
        if obs.time - start > limit + 1.0:  # a clock that stalls cannot hold the script forever
            return ScriptRun(start, obs.time, "timeout", list(engine.transitions))
        obs = servos.track(target)


def follow_path(servos: Servos, arm: PlanarArm, path: np.ndarray, speed: float, waist: float, *,
                pitch_radius: float = 0.5, settle_s: float = 0.5) -> np.ndarray:
    """Drive the bucket tip along the pose polyline ``path`` (n, 3) (x m, z m, pitch rad) in the
    plane at swing angle ``waist`` [rad] at ``speed`` [m/s] through IK, then hold the end for
    ``settle_s``; returns the joint angles (6,) at the end."""
    follower = PathFollower(np.asarray(path, dtype=float), speed, pitch_radius)
    obs = servos.observe()
    target = np.array(obs.q, dtype=float)
    target[0], target[4:] = waist, 0.0
    while not follower.at_end:
        q, ok = arm.inverse(follower.advance(servos.control_dt))
        if ok:
            target[1:4] = q
        obs = servos.track(target)
    for _ in range(int(settle_s / servos.control_dt)):
        obs = servos.track(target)
    return np.array(obs.q, dtype=float)
