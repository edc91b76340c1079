"""The trenching dig script and its executor (000_a3ca905d8c6d92bf.txt §7.1.3, 001_0de172b0d6b3614b.txt §4).

:func:`dig_script` fills the fixed structure of a dig with the numbers of one plan. The arm group
(shoulder, elbow, wrist pitch) runs: move above the entry; **touch-down** (descend until the F/T
force stays above a threshold for three control ticks, the ``contact`` event); **dig** along the planned path shifted by the offset touch-down found;
**lift out**; **dump** once the waist has reached the spoil side; **park** once the bucket reads
empty. The waist runs: turn to the dig plane; when the arm has lifted, swing to the spoil area; when
the bucket is empty, swing to park. Couplings are conditions on the other joints and on events the
executor raises (``contact``, ``path_done``, ``lifted``, ``empty``).

:class:`DigExecutor` ticks the :class:`~excavsim.execution.script.ScriptEngine` at the control rate,
turns Cartesian path commands into joint targets through IK, watches for **stalls** (a joint at its
relief limit that lags its target for ``stall_time_s``): the dig is then stopped and the bucket
backed out along the path it took, before lifting, dumping and parking as usual. With compliance on
(off by default) the remaining dig path rises while a joint nears its relief limit (see
:meth:`DigExecutor._yield`), so a dig in soil stiffer than planned can still finish. No physical
failure raises: the :class:`ExecutionRecord` says what happened.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from excavsim import constants
from excavsim.config import ExecutorConfig
from excavsim.errors import ExcavsimError
from excavsim.execution.conditions import Sense, all_of, always, any_of, event, reached
from excavsim.execution.script import Command, Script, ScriptEngine, Step, SubScript
from excavsim.handoff.dig import DigPlan, ExecutionRecord
from excavsim.handoff.observation import Observation, Servos
from excavsim.robot.fast import arm_params, ik_torques
from excavsim.robot.kinematics import PlanarArm
from excavsim.sensing.ft import ForceSensor

ARM = ("shoulder_joint", "elbow_joint", "wrist_pitch_joint")
WAIST = "waist_joint"


def touch_pitch(plan: DigPlan, arm: PlanarArm, cfg: ExecutorConfig) -> float:
    """The flattest pitch, from ``touch_pitch_deg`` up to the entry's, at which the whole vertical
    touch-down descent above the entry is reachable [rad]."""
    entry = plan.poses[0]
    for deg in np.arange(cfg.touch_pitch_deg, math.degrees(entry[2]) + 5.0, 5.0):
        pitch = min(math.radians(deg), float(entry[2]))
        z = np.linspace(entry[1] - cfg.touch_search_m, entry[1] + cfg.approach_height_m, 8)
        if arm.reachable(np.stack([np.full(8, entry[0]), z, np.full(8, pitch)], axis=-1)).all():
            return pitch
    return float(entry[2])


def dig_script(plan: DigPlan, arm: PlanarArm, cfg: ExecutorConfig, park: np.ndarray) -> Script:
    """The trenching dig script with this plan's numbers (see the module docstring); ``park`` (6,)
    is the model's park keyframe [rad]."""
    entry = plan.poses[0]
    above = np.array([entry[0], entry[1] + cfg.approach_height_m, touch_pitch(plan, arm, cfg)])
    q_above, ok = arm.inverse(above)
    pre_dump = np.array([cfg.dump_pose[0], cfg.dump_pose[1], plan.poses[-1, 2]])
    q_dump, ok_dump = arm.inverse(pre_dump)
    if not ok or not ok_dump:
        raise ExcavsimError(f"dig script: the pose above the entry {above.round(3)} or the dump pose "
                            f"{cfg.dump_pose} is out of reach")
    park = np.asarray(park, dtype=float)[:4]
    tol = cfg.settle_tol_rad
    late = event("step_timeout")  # a move that does not settle in time does not hang the dig
    at_above = any_of(all_of(*(reached(j, tol) for j in (WAIST,) + ARM)), late)
    arm_steps = (
        Step("above entry", always(), Command(tuple(q_above))),
        Step("touch-down", at_above, Command(path="touchdown")),
        Step("dig", event("contact"), Command(path="dig")),
        Step("lift out", any_of(event("path_done:dig"), late), Command(path="lift")),
        Step("hold lifted", any_of(event("path_done:lift"), late), Command()),
        Step("over spoil", any_of(reached(WAIST, tol), late), Command(tuple(q_dump))),
        Step("dump", any_of(all_of(*(reached(j, tol) for j in ARM)), late), Command(path="dump")),
        Step("park", any_of(event("empty"), late), Command(tuple(park[1:]))),
    )
    waist_steps = (
        Step("dig plane", always(), Command((plan.waist,))),
        Step("swing to spoil", any_of(event("path_done:lift"), event("lift_timeout")),
             Command((math.radians(cfg.spoil_waist_deg),))),
        Step("swing to park", event("empty"), Command((park[0],))),
    )
    return Script("trench dig", (SubScript(ARM, arm_steps), SubScript((WAIST,), waist_steps)))


class DigExecutor:
    """Runs one planned dig in the simulation (see the module docstring).

    Args:
        sim: the servos and sensors it drives (the world's Simulation, seen as :class:`Servos`).
        arm: the robot's planar kinematics.
        cfg: the script's numbers.
        ft: the wrist F/T sensor reporting at the bucket tip.
        park: (6,) joint angles of the park pose, the model's keyframe [rad].
    """

    def __init__(self, sim: Servos, arm: PlanarArm, cfg: ExecutorConfig, ft: ForceSensor, park: np.ndarray):
        self.sim = sim
        self.arm = arm
        self.cfg = cfg
        self.ft = ft
        self.park = np.asarray(park, dtype=float)
        names = list(constants.JOINTS)
        self._arm_idx = [names.index(j) for j in ARM]
        self._waist_idx = names.index(WAIST)
        self._names = names
        # compiled elbow-up IK for the one pose of each control step (equal to PlanarArm.inverse)
        self._ik_params = arm_params(arm)
        self._ik_buf = (np.zeros((1, 3)), np.zeros((1, 3)), np.zeros(1), np.zeros((1, 3)), np.zeros(1, bool),
                        np.zeros((1, 3)))
        self._geometry: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    def _inverse(self, pose: np.ndarray) -> tuple[np.ndarray, bool]:
        poses, wrench, payload, q, ok, tau = self._ik_buf
        poses[0] = pose
        ik_torques(self._ik_params, poses, wrench, payload, np.zeros(2), False, q, ok, tau)
        return q[0].copy(), bool(ok[0])

    def _cum(self, path: np.ndarray) -> np.ndarray:
        """Cumulative length along ``path`` (cached per path array while it is in use)."""
        hit = self._geometry.get(id(path))
        if hit is None or hit[0] is not path:
            hit = (path, np.concatenate([[0.0], np.cumsum(_seg(path))]))
            self._geometry[id(path)] = hit
        return hit[1]

    def run(self, plan: DigPlan, *, on_phase: Callable[[str, ExecutionRecord], None] | None = None
            ) -> ExecutionRecord:
        """Execute ``plan``; never raises for a physical failure (the record's ``outcome`` says).

        Args:
            plan: the dig.
            on_phase: called with each step name of the arm's script as it starts, and with
                "no contact" when the touch-down finds nothing, together with the record so far:
                the loop measures the world there (the soil in the bucket at lift-out), which the
                executor itself never reads.
        """
        cfg = self.cfg
        sim = self.sim
        announce = on_phase or (lambda _name, _rec: None)
        rec = ExecutionRecord(planned_volume_m3=plan.volume_m3)
        script = dig_script(plan, self.arm, cfg, self.park)
        rec.script_text = script.describe()
        engine = ScriptEngine(script)
        entry = plan.poses[0]
        rec.touch_expected_z = float(entry[1])
        tp = touch_pitch(plan, self.arm, cfg)
        paths: dict[str, np.ndarray] = {
            "touchdown": np.array([[entry[0], entry[1] + cfg.approach_height_m, tp],
                                   [entry[0], entry[1] - cfg.touch_search_m, tp]]),
        }
        cursor: dict[str, float] = {}
        events: set[str] = set()
        target = sim.observe().q.copy()
        target[[self._names.index(j) for j in constants.JOINTS[4:]]] = 0.0  # wrist yaw and roll stay at 0
        stall_since = None
        empty_since = None
        contact_ticks = 0
        lead_len = 0.0
        rise = 0.0  # compliant rise of the remaining dig path [m]
        t0 = sim.time
        max_time = 8 * cfg.move_timeout_s
        obs = sim.observe()
        phase_start: dict[str, float] = {}
        while True:
            reading = self.ft.reading(obs)
            q = obs.q
            sense = Sense(obs.time, dict(zip(self._names, q)), dict(zip(self._names, obs.qdot)),
                          dict(zip(self._names, obs.actuator_force)), reading.force_tip, frozenset(events))
            n_before = len(engine.transitions)
            commands = engine.tick(sense)
            for tr in engine.transitions[n_before:]:
                phase_start[tr.name] = tr.time
                if tr.subscript == 0:
                    if "step_timeout" in events and tr.name == "hold lifted":
                        events.add("lift_timeout")  # the waist swings even if the lift never settled
                    events.discard("step_timeout")
                if tr.name == "dig":  # contact: shift the planned path by what touch-down found
                    tip = self.arm.forward(q[self._arm_idx])
                    rec.touch_found_z = float(tip[1])
                    rec.touch_offset_m = float(tip[1] + cfg.touch_sink_m - entry[1])
                    if abs(rec.touch_offset_m) > cfg.touch_warn_m:
                        kind = "below" if rec.touch_offset_m < 0 else "above"
                        rec.warnings.append(
                            f"contact {100 * abs(rec.touch_offset_m):.1f} cm {kind} the map: "
                            + ("the map is high, or the bucket overshot before the force registered (Fig. 104)"
                               if kind == "below" else "the map is low, or terrain interferes before the entry "
                                                       "(Fig. 105)"))
                    shifted = plan.poses.copy()
                    shifted[:, 1] += float(np.clip(rec.touch_offset_m, *plan.shift_bounds_m))
                    # lead-in: back up clear of the soil, turn to the entry pitch in the air, go in
                    clear = shifted[0, 1] + 0.03
                    lead = np.array([tip, [tip[0], clear, tip[2]], [shifted[0, 0], clear, shifted[0, 2]]])
                    paths["dig"] = np.concatenate([lead, shifted])
                    lead_len = _length(np.concatenate([lead, shifted[:1]]))
                    rec.planned_path = shifted
                if tr.name == "dump":
                    here = self.arm.forward(q[self._arm_idx])
                    paths["dump"] = np.array([here, [here[0], here[1], math.radians(cfg.dump_pose[2])]])
                if tr.name == "lift out":
                    end = self.arm.forward(q[self._arm_idx])
                    paths["lift"] = np.array([end, [end[0], max(cfg.lift_height_m, end[1]), end[2]]])
                if tr.subscript == 0:
                    announce(tr.name, rec)
            # contact: the F/T force stays above the threshold for a few samples once the descent runs
            if engine.current(0).name == "touch-down" and obs.time - phase_start["touch-down"] > 0.3:
                contact_ticks = contact_ticks + 1 if np.linalg.norm(reading.force_tip) > cfg.touch_force_n else 0
                if contact_ticks >= 3:
                    events.add("contact")
            # the touch-down ran out without contact
            if engine.current(0).name == "touch-down" and cursor.get("touchdown", 0.0) >= _length(paths["touchdown"]):
                if self._settled(q, target):
                    rec.outcome = "no contact"
                    announce("no contact", rec)
                    rec.warnings.append(f"no contact within {100 * cfg.touch_search_m:.0f} cm below the map")
                    self._park(rec)
                    break
            # commands -> joint targets
            for i, cmd in enumerate(commands):
                joints = script.subscripts[i].joints
                idx = [self._names.index(j) for j in joints]
                if cmd.path:
                    path = paths[cmd.path]
                    s = cursor.get(cmd.path, 0.0)
                    speed = cfg.touch_speed_m_s if cmd.path == "touchdown" else cfg.path_speed_m_s
                    cum = self._cum(path)
                    s = min(s + speed * sim.control_dt, float(cum[-1]))
                    cursor[cmd.path] = s
                    pose = _point_at(path, s, cum)
                    if cmd.path == "dig" and cfg.compliance != "off" and rec.stall is None and s >= lead_len:
                        rise = self._yield(rise, obs, reading)
                        pose = pose + np.array([0.0, rise, 0.0])
                        rec.compliance.append(rise)
                    qp, ok = self._inverse(pose)
                    if ok:
                        target[idx] = qp
                    if s >= cum[-1] and self._settled(q[idx], target[idx]):
                        events.add(f"path_done:{cmd.path}")
                elif cmd.targets:
                    target[idx] = cmd.targets
            # stall watch while digging
            if engine.current(0).name == "dig" and rec.stall is None and cursor.get("dig", 0.0) >= lead_len:
                rec.executed_path.append(self.arm.forward(q[self._arm_idx]))
                lim = sim.torque_limit[self._arm_idx]
                saturated = np.abs(obs.actuator_force[self._arm_idx]) >= cfg.stall_torque_fraction * lim
                lagging = np.abs(q[self._arm_idx] - target[self._arm_idx]) > cfg.stall_error_rad
                bad = saturated & lagging
                if bad.any():
                    stall_since = obs.time if stall_since is None else stall_since
                    if obs.time - stall_since >= cfg.stall_time_s:
                        j = ARM[int(np.argmax(bad))]
                        tip = self.arm.forward(q[self._arm_idx])
                        rec.stall = {"joint": j, "time": obs.time, "tip": tip,
                                     "torque": float(obs.actuator_force[self._names.index(j)])}
                        back = np.asarray(rec.executed_path)[::-1]
                        paths["dig"] = back  # back out along the path taken
                        cursor["dig"] = 0.0
                        target[self._arm_idx] = q[self._arm_idx]
                else:
                    stall_since = None
            # the bucket is empty when the F/T force stays low at the dump pose
            if (engine.current(0).name == "dump" and "path_done:dump" in events
                    and self._settled(q[self._arm_idx], target[self._arm_idx])):
                if np.linalg.norm(reading.force_tip) < cfg.empty_force_n:
                    empty_since = obs.time if empty_since is None else empty_since
                    if obs.time - empty_since >= 0.5:
                        events.add("empty")
                else:
                    empty_since = None
            if len(rec.times) == 0 or obs.time - rec.times[-1] >= 1.0 / self.ft.rate_hz - 1e-9:
                rec.times.append(obs.time)
                rec.ft.append((obs.time, reading.force_tip.copy()))
                rec.torques.append(obs.actuator_force.copy())
            step = engine.current(0).name
            if obs.time - phase_start.get(step, obs.time) > cfg.move_timeout_s and "step_timeout" not in events:
                err = np.abs(q - target)
                events.add("step_timeout")
                rec.warnings.append(f"step {step!r} did not settle within {cfg.move_timeout_s:.0f} s "
                                    f"(largest joint error {np.degrees(err.max()):.1f} deg at "
                                    f"{self._names[int(np.argmax(err))]}); moving on")
            if step == "park" and (self._settled(q, target) or "step_timeout" in events):
                late = any("did not settle" in w for w in rec.warnings)
                rec.outcome = "stalled" if rec.stall else ("completed late" if late else "completed")
                break
            if obs.time - t0 > max_time:
                rec.outcome = f"timeout in step {engine.current(0).name!r}"
                break
            try:
                obs = sim.track(target)
            except ExcavsimError as exc:  # a physical failure of the simulation: report, do not raise
                rec.outcome = f"simulation failure: {exc}"
                break
        names = [tr.name for tr in engine.transitions if tr.subscript == 0]
        times = [tr.time for tr in engine.transitions if tr.subscript == 0] + [obs.time]
        rec.phase_times = {n: times[i + 1] - times[i] for i, n in enumerate(names)}
        rec.phase_starts = {n: times[i] for i, n in enumerate(names)}
        return rec

    def _yield(self, rise: float, obs: Observation, reading) -> float:
        """Compliant path modification (simplified §5.4): the remaining dig path rises while the most
        loaded planar joint is above ``compliance_torque_ratio`` of its relief limit.

        Eqs. 35-37 turn a force error into a path change through ``(J^T K)^-1``; the soil's push on
        a raked blade points down and back, so yielding along it would deepen the cut. The change
        that lowers every joint's load is a shallower cut, so the path rises at
        ``gain x (ratio - threshold)``, up to ``compliance_max_m``, from the measured actuator torques
        (the joint-space form the thesis mentions). In ``impedance`` mode the gain grows with the
        soil's force/velocity ratio from the F/T and the tip speed (DiMaio ch. 3.3.4): the stiffer the
        soil feels, the softer the bucket becomes.
        """
        cfg = self.cfg
        ratio = float(np.max(np.abs(obs.actuator_force[self._arm_idx]) / self.sim.torque_limit[self._arm_idx]))
        gain = cfg.compliance_gain_m_s
        if cfg.compliance == "impedance":
            v = float(np.linalg.norm((self.arm.jacobian(obs.q[self._arm_idx]) @ obs.qdot[self._arm_idx])[:2]))
            gain *= 1.0 + float(np.linalg.norm(reading.force_tip)) / max(v, 0.01) / cfg.impedance_ref_n_s_per_m
        rise += gain * max(ratio - cfg.compliance_torque_ratio, 0.0) * self.sim.control_dt
        return min(rise, cfg.compliance_max_m)

    def _settled(self, q: np.ndarray, target: np.ndarray) -> bool:
        return bool(np.all(np.abs(np.asarray(q) - np.asarray(target)) <= self.cfg.settle_tol_rad))

    def _park(self, rec: ExecutionRecord) -> None:
        """Move straight to the park pose (after a failure)."""
        park = self.park
        lift = self.sim.observe().q.copy()
        tip = self.arm.forward(lift[self._arm_idx])
        q_up, ok = self.arm.inverse(np.array([tip[0], self.cfg.lift_height_m, tip[2]]))
        steps = int(self.cfg.move_timeout_s / self.sim.control_dt)
        if ok:
            lift[self._arm_idx] = q_up
            for _ in range(steps):
                if self._settled(self.sim.track(lift).q, lift):
                    break
        for _ in range(steps):
            if self._settled(self.sim.track(park).q, park):
                break


PITCH_RADIUS_M = 0.5  # a turn of the bucket counts as this radius times the angle along a path


def _seg(path: np.ndarray) -> np.ndarray:
    """Lengths of a pose polyline's segments: position, and pitch turned at PITCH_RADIUS_M [m]."""
    d = np.diff(path, axis=0)
    return np.sqrt(d[:, 0] ** 2 + d[:, 1] ** 2 + (PITCH_RADIUS_M * d[:, 2]) ** 2)


def _length(path: np.ndarray) -> float:
    return float(_seg(path).sum()) if len(path) > 1 else 0.0


def _point_at(path: np.ndarray, s: float, cum: np.ndarray | None = None) -> np.ndarray:
    """Pose at path length ``s`` along a polyline of poses (see :func:`_seg`); ``cum`` is the
    cumulative length along it when already known."""
    if cum is None:
        cum = np.concatenate([[0.0], np.cumsum(_seg(path))])
    if cum[-1] <= 0:
        return path[-1].copy()
    return np.array([np.interp(s, cum, path[:, k]) for k in range(3)])
