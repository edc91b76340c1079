"""The trenching dig script and its executor (Singh 1995 §7.1.3, Rowe 1997 §4).

:func:`dig_script` fills the fixed structure of a dig with the numbers of one plan. The arm group
(shoulder, elbow, wrist pitch) runs: move above the entry; **touch-down** (descend until the F/T
force stays above a threshold for a few control ticks, which raises ``contact``; aborted as
"no contact" when the descent ends settled without it); **dig** along the planned path shifted by
the offset touch-down found; **lift out**; **dump** once the waist has reached the spoil side,
raising ``empty`` when the F/T force stays low at the settled dump pose; **park** once the bucket is
empty, which ends the script when every joint has settled. The waist runs: turn to the dig plane;
when the lift is done (or the arm has given up on it), swing to the spoil area; when the bucket is
empty, swing to park. Wrist yaw and roll stay level. Every arm step times out after
``move_timeout_s`` and the next one starts anyway (the dig is then "completed late"), but a
touch-down that times out still waits for contact; the whole script stops after
``dig_timeout_moves`` of those.

:class:`DigExecutor` ticks the :class:`~excavsim.execution.script.ScriptEngine` at the control rate,
lays out each named path when its step starts, follows it and turns it into joint targets through
IK, watches for **stalls** (a joint at its relief limit that lags its target for ``stall_time_s``):
the dig is then stopped and the bucket backed out along the path it took, before lifting, dumping
and parking as usual. With compliance on (off by default) the remaining dig path rises while a
joint nears its relief limit (see :meth:`DigExecutor._yield`), so a dig in soil stiffer than planned
can still finish. No physical failure raises: the :class:`ExecutionRecord` says what happened.
When the world reports that its physics diverged (:class:`~excavsim.handoff.observation.Diverged`)
the dig ends at once with outcome ``diverged``; when the episode's wall-clock limit passes
(:class:`~excavsim.handoff.observation.OutOfTime`), with ``timeout: ...``. Besides the script's own
time limit in simulated time, the executor counts its control steps and stops the script as
``timeout in step ...`` once they cover that limit, so a clock that stalls cannot hold a dig forever.

On a lightly damped arm (the world's ``truth.arm_damping_ratio``, Singh 1995 §7.1.3, Fig. 104)
two numbers make the touch-down cope, both off by default: ``touch_quiet_s`` starts the descent only
once the F/T has stayed under ``touch_quiet_n`` that long, so the ringing after the move above the
entry is not taken for contact; ``joint_give_rad_per_nm`` (calibrated) takes the give that the
encoders miss (``truth.arm_give_share``) off their angles in everything the executor decides, and
commands the encoders ahead by the give at the low-passed torques, so that the links, not the
encoders, follow the path.

Speed: the loop runs every control step (38 000 in the default episode). By default the executor
runs the script on a :class:`~excavsim.execution.script.CompiledEngine` and does a tick's work in
one or two calls of the compiled :func:`_tick_kernel` (the engine's tick, the path cursor, IK, the
report, the stall watch, the engine's end of tick), with the F/T reading from
:meth:`~excavsim.sensing.ft.ForceSensor.reading_into`; Python only lays out paths, announces steps,
records at the F/T rate and handles stalls and timeouts. ``DigExecutor(..., reference=True)`` (and
compliance, which the compiled loop does not do) runs the original Python loop on
:class:`~excavsim.execution.script.ScriptEngine`: both give the same dig to the bit (tested).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numba
import numpy as np

from excavsim import constants
from excavsim.config import ExecutorConfig
from excavsim.errors import ConfigError, Diverged, ExcavsimError, GoalError, OutOfTime
from excavsim.execution.conditions import (Sense, all_of, always, any_of, event, force_above, force_below, held,
                                           past, path_done, path_end, reached, settled, started, timed_out)
from excavsim.execution.paths import PathFollower, interp_pose, path_length
from excavsim.execution.script import (_S_PATH, _S_TG0, _S_TGN, Abort, Command, CompiledEngine, Script, ScriptEngine,
                                       Step, Stop, SubScript, Transition, Watch, engine_end_tick, engine_report,
                                       engine_tick)
from excavsim.handoff.dig import DigPlan, ExecutionRecord
from excavsim.handoff.observation import Observation, Servos
from excavsim.robot.fast import arm_params, chain_lengths, forward_pose, ik_torques, solve_pose
from excavsim.robot.kinematics import PlanarArm
from excavsim.robot.machine import T3, Machine
from excavsim.sensing.ft import ForceSensor, FTReading

ARM = constants.PLANAR_JOINTS
WAIST = "waist_joint"
WRIST = ("wrist_yaw_joint", "wrist_roll_joint")
ARM_SUB = 0  # the arm's sub-script comes first in the dig script
GIVE_FILTER_S = 0.3  # time constant of the torques the give compensation commands from (tuned; 0.1-1 s work) [s]


def touch_pitch(plan: DigPlan, arm: PlanarArm, cfg: ExecutorConfig) -> float:
    """The flattest pitch, from ``touch_pitch_deg`` up to the entry's, at which the whole vertical
    touch-down descent above the entry is reachable [rad]."""
    entry = plan.poses[0]
    step, n = cfg.touch_pitch_step_deg, cfg.touch_reach_checks
    for deg in np.arange(cfg.touch_pitch_deg, math.degrees(entry[2]) + step, step):
        pitch = min(math.radians(deg), float(entry[2]))
        z = np.linspace(entry[1] - cfg.touch_search_m, entry[1] + cfg.approach_height_m, n)
        if arm.reachable(np.stack([np.full(n, entry[0]), z, np.full(n, pitch)], axis=-1)).all():
            return pitch
    return float(entry[2])


def expected_contact_z(plan: DigPlan, arm: PlanarArm, pitch: float) -> float:
    """The tip's height when the bucket, descending vertically over the entry at ``pitch`` [rad], first
    meets the mapped surface of ``plan`` (§7.1.3): where its lowest point over the map touches, which
    on a slope is the heel or the bottom, not the edge (Fig. 105). Without a surface: the entry's height."""
    entry = plan.poses[0]
    if plan.surface is None:
        return float(entry[1])
    pts = arm.bucket_points(np.array([entry[0], 0.0, pitch]))  # the outline with the tip at height 0
    return float(np.max(plan.surface(pts[:, 0]) - pts[:, 1]))


def dig_script(plan: DigPlan, arm: PlanarArm, cfg: ExecutorConfig, park: np.ndarray, machine: Machine = T3) -> Script:
    """The trenching dig script with this plan's numbers (see the module docstring); ``park`` is the
    model's park keyframe in the order of ``machine.joints`` [rad]. Its paths (touchdown, dig, lift, dump)
    are laid out by the executor when their steps start. The script runs on ``machine``'s joints: its
    waist (the T3's waist, an excavator's swing), its planar chain, and its held joints (the T3's wrist
    yaw and roll, level; an excavator has none)."""
    entry = plan.poses[0]
    above = np.array([entry[0], entry[1] + cfg.approach_height_m, touch_pitch(plan, arm, cfg)])
    q_above, ok = arm.inverse(above)
    pre_dump = np.array([cfg.dump_pose[0], cfg.dump_pose[1], plan.poses[-1, 2]])
    q_dump, ok_dump = arm.inverse(pre_dump)
    if not ok or not ok_dump:
        raise GoalError(f"dig script: the pose above the entry {above.round(3)} or the dump pose "
                        f"{cfg.dump_pose} is out of reach")
    park = np.asarray(park, dtype=float)
    park_waist, park_arm = float(park[machine.index((machine.waist,))[0]]), park[machine.index(machine.planar)]
    arm_joints, waist, every = machine.planar, machine.waist, machine.joints
    tol = cfg.settle_tol_rad
    wait = cfg.move_timeout_s
    late = timed_out()  # a move that does not settle in time does not hang the dig

    def follow(path: str, speed: float) -> Command:
        return Command(path=path, speed=speed, tol=tol)

    contact = Watch("contact", all_of(past(cfg.touch_ignore_s),
                                      held(force_above(cfg.touch_force_n), ticks=cfg.touch_contact_ticks)))
    no_contact = Abort("no contact", all_of(path_end("touchdown"), settled(every, tol)),
                       f"no contact within {100 * cfg.touch_search_m:.0f} cm below the map")
    empty = Watch("empty", all_of(path_done("dump"), settled(arm_joints, tol),
                                  held(force_below(cfg.empty_force_n), seconds=cfg.empty_hold_s)))
    above_settled = settled((waist,) + arm_joints, tol)
    if cfg.touch_quiet_s > 0:  # wait for the arm's ringing to die down (§7.1.3); held first, so it counts every tick
        above_settled = all_of(held(force_below(cfg.touch_quiet_n), seconds=cfg.touch_quiet_s), above_settled)
    arm_steps = (
        Step("above entry", always(), Command(tuple(q_above)), wait),
        Step("touch-down", any_of(above_settled, late), follow("touchdown", cfg.touch_speed_m_s), wait,
             watches=(contact,), abort=no_contact),
        Step("dig", event("contact"), follow("dig", cfg.path_speed_m_s), wait),
        Step("lift out", any_of(path_done("dig"), late), follow("lift", cfg.path_speed_m_s), wait),
        Step("hold lifted", any_of(path_done("lift"), late), Command(), wait),
        Step("over spoil", any_of(reached(waist, tol), late), Command(tuple(q_dump)), wait),
        Step("dump", any_of(settled(arm_joints, tol), late), follow("dump", cfg.path_speed_m_s), wait,
             watches=(empty,)),
        Step("park", any_of(event("empty"), late), Command(tuple(park_arm)), wait,
             ends=any_of(settled(every, tol), late)),
    )
    waist_steps = (
        Step("dig plane", always(), Command((plan.waist,))),
        # the waist swings even if the lift never settled: the arm holds once the lift timed out
        Step("swing to spoil", any_of(path_done("lift"), started("hold lifted")),
             Command((math.radians(cfg.spoil_waist_deg),))),
        Step("swing to park", event("empty"), Command((park_waist,))),
    )
    subs = (SubScript(arm_joints, arm_steps), SubScript((waist,), waist_steps))
    if machine.held:
        still = tuple(name for name, _ in machine.held)
        subs += (SubScript(still, (Step("level", always(), Command(tuple(v for _, v in machine.held))),)),)
    return Script("trench dig", subs, timeout_s=cfg.dig_timeout_moves * wait)


class DigExecutor:
    """Runs one planned dig in the simulation (see the module docstring).

    Args:
        sim: the servos and sensors it drives (the world's Simulation, seen as :class:`Servos`).
        arm: the robot's planar kinematics.
        cfg: the script's numbers.
        ft: the wrist F/T sensor reporting at the bucket tip.
        park: joint angles of the park pose, the model's keyframe, in ``machine.joints`` order [rad].
        reference: run the original Python loop (:class:`ScriptEngine`, :meth:`ForceSensor.reading`)
            instead of the compiled one; the same dig to the bit, ten times slower.
        machine: the joints the script runs on (default the T3's). A machine with hydraulics has torque
            limits that vary with the pose (relief pressure x area x moment arm): the stall watch then
            reads ``sim.torque_limit`` afresh every control step.
    """

    def __init__(self, sim: Servos, arm: PlanarArm, cfg: ExecutorConfig, ft: ForceSensor, park: np.ndarray, *,
                 reference: bool = False, machine: Machine = T3):
        self.sim = sim
        self.reference = reference
        self.arm = arm
        self.cfg = cfg
        self.ft = ft
        self.park = np.asarray(park, dtype=float)
        self.machine = machine
        names = list(machine.joints)
        self._arm_idx = machine.index(machine.planar)
        self._names = names
        self._limits_vary = machine.hydraulics is not None
        # compiled elbow-up IK for the one pose of each control step (equal to PlanarArm.inverse)
        self._ik_params = arm_params(arm)
        self._ik_buf = (np.zeros((1, 3)), np.zeros((1, 3)), np.zeros(1), np.zeros((1, 3)), np.zeros(1, bool),
                        np.zeros((1, 3)))
        # the joints' give that the encoders miss, per N m (calibrated; None: the encoders are the links)
        self._give: np.ndarray | None = None
        self._tau_f: np.ndarray | None = None  # the low-passed torques of _servo_target
        if any(cfg.joint_give_rad_per_nm):
            self._give = np.zeros(len(names))
            self._give[self._arm_idx] = cfg.joint_give_rad_per_nm

    def _estimate(self, obs: Observation) -> Observation:
        """The observation with the links' angles estimated from the encoders and the actuator torques
        (``joint_give_rad_per_nm``): the angles every decision of the executor uses."""
        if self._give is None:
            return obs
        return dataclasses.replace(obs, q=obs.q - self._give * obs.actuator_force)

    def _servo_target(self, target: np.ndarray, obs: Observation) -> np.ndarray:
        """The encoders' target for the links' ``target``: ahead of it by the give at the torques, low-passed
        over ``GIVE_FILTER_S`` (the instantaneous torques feed the arm's ringing back into the servo
        and make it oscillate; the load the give comes from, weight and soil, changes slowly)."""
        if self._give is None:
            return target
        if self._tau_f is None:
            self._tau_f = np.array(obs.actuator_force, dtype=float)
        self._tau_f += (1.0 - math.exp(-self.sim.control_dt / GIVE_FILTER_S)) * (obs.actuator_force - self._tau_f)
        return target + self._give * self._tau_f

    def _inverse(self, pose: np.ndarray) -> tuple[np.ndarray, bool]:
        poses, wrench, payload, q, ok, tau = self._ik_buf
        poses[0] = pose
        ik_torques(self._ik_params, poses, wrench, payload, np.zeros(2), False, q, ok, tau)
        return q[0].copy(), bool(ok[0])

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
        sim = self.sim
        self._tau_f = None
        announce = on_phase or (lambda _name, _rec: None)
        expected = expected_contact_z(plan, self.arm, touch_pitch(plan, self.arm, self.cfg))
        rec = ExecutionRecord(planned_volume_m3=plan.volume_m3, touch_expected_z=expected)
        script = dig_script(plan, self.arm, self.cfg, self.park, self.machine)
        rec.script_text = script.describe()
        weighed: list[float] = []  # F/T weight of the load while the lifted bucket is held [N]
        target = self._estimate(sim.observe()).q.copy()  # hold still until the first commands (F/T noise drawn too)
        obs = self._estimate(sim.observe())
        # the script's time limit counted in steps (the engine's own check reads the clock, a tick earlier)
        max_steps = math.ceil(script.timeout_s / sim.control_dt) + 2 if script.timeout_s else math.inf
        compiled = not self.reference and self.cfg.compliance == "off" and all(
            not st.command.path for k, sub in enumerate(script.subscripts) if k != ARM_SUB for st in sub.steps)
        loop = self._loop if compiled else self._loop_reference
        engine, obs = loop(plan, script, rec, target, obs, weighed, max_steps, announce)
        if engine.stop is not None:
            try:
                self._conclude(rec, engine.stop, bool(engine.timeouts), announce)
            except ExcavsimError as exc:  # while parking after an abort
                self._failed(rec, exc)
        rec.lifted_load_n = float(np.median(weighed)) if weighed else math.nan
        names = [tr.name for tr in engine.transitions if tr.subscript == ARM_SUB]
        times = [tr.time for tr in engine.transitions if tr.subscript == ARM_SUB] + [obs.time]
        rec.phase_times = {n: times[i + 1] - times[i] for i, n in enumerate(names)}
        rec.phase_starts = {n: times[i] for i, n in enumerate(names)}
        return rec

    def _loop(self, plan: DigPlan, script: Script, rec: ExecutionRecord, target: np.ndarray, obs: Observation,
              weighed: list[float], max_steps: float, announce: Callable[[str, ExecutionRecord], None]
              ) -> tuple[CompiledEngine, Observation]:
        """The control loop, compiled: :meth:`_loop_reference`'s work in the same order, with a tick's
        per-step part in :func:`_tick_kernel` (see the module docstring). Returns the engine and the
        last observation."""
        sim, cfg = self.sim, self.cfg
        engine = CompiledEngine(script, self._names)
        prog, state = engine.prog, engine.state
        paths: list[PathFollower | None] = [None] * len(script.subscripts)
        arm_idx = np.asarray(self._arm_idx, dtype=np.int64)
        limit = np.asarray(sim.torque_limit, dtype=np.float64)[arm_idx]
        # cursor s, speed, end, cut_from, stall since (NaN: not), control dt, stall fraction, error, time
        fs = np.array([0.0, 0.0, 0.0, math.inf, math.nan, sim.control_dt, cfg.stall_torque_fraction,
                       cfg.stall_error_rad, cfg.stall_time_s])
        out = np.zeros(4, dtype=np.int64)  # stalled joint
        pose = np.zeros(3)
        ftw = np.zeros((4, 3))
        chain = np.array(chain_lengths(self._ik_params))
        no_path = np.zeros((1, 3)), np.zeros(1)
        path_arrays = no_path
        hold_lifted = [st.name for st in script.subscripts[ARM_SUB].steps].index("hold lifted") \
            if any(st.name == "hold lifted" for st in script.subscripts[ARM_SUB].steps) else -1
        period = 1.0 / self.ft.rate_hz - 1e-9
        last_record = -math.inf
        steps = 0
        while True:
            self.ft.reading_into(obs, ftw)
            q = obs.q
            if self._limits_vary:  # the relief torques at this pose
                limit[:] = np.asarray(sim.torque_limit, dtype=np.float64)[arm_idx]
            flags = _tick_kernel(True, prog, state, obs.time, q, obs.actuator_force, ftw, target, arm_idx,
                                 self._ik_params, chain, path_arrays[0], path_arrays[1], fs, limit, pose, out)
            if flags & _F_TICKED:  # new steps (lay out their paths, announce them) or an abort
                engine._sync()
                for tr in engine.transitions[len(engine.transitions) - int(out[1]):]:
                    cmd = script.subscripts[tr.subscript].steps[tr.step].command
                    paths[tr.subscript] = self._lay_out(cmd, q, plan, rec) if cmd.path else None
                    if tr.subscript == ARM_SUB:
                        p = paths[ARM_SUB]
                        path_arrays = (p._path, p.cum) if p is not None else no_path
                        fs[:4] = (p.s, p.speed, p._end, p.cut_from) if p is not None else (0.0, 0.0, 0.0, math.inf)
                        announce(tr.name, rec)
                if engine.stop is not None:
                    break
                flags = _tick_kernel(False, prog, state, obs.time, q, obs.actuator_force, ftw, target, arm_idx,
                                     self._ik_params, chain, path_arrays[0], path_arrays[1], fs, limit, pose, out)
            if flags & (_F_LATE | _F_STOP):
                engine._sync()
            p = paths[ARM_SUB]
            if p is not None:
                p.s = float(fs[0])
                if flags & _F_CUT:
                    rec.executed_path.append(pose.copy())
                if flags & _F_STALL:
                    j = int(out[0])
                    rec.stall = {"joint": self.machine.planar[j], "time": obs.time, "tip": pose.copy(),
                                 "torque": float(obs.actuator_force[self._arm_idx[j]])}
                    target[self._arm_idx] = q[self._arm_idx]
                    p = paths[ARM_SUB] = PathFollower(np.asarray(rec.executed_path)[::-1], p.speed, cfg.pitch_radius_m)
                    path_arrays = (p._path, p.cum)
                    fs[:4] = (p.s, p.speed, p._end, p.cut_from)
            if obs.time - last_record >= period:  # _record
                last_record = obs.time
                rec.times.append(obs.time)
                rec.ft.append((obs.time, ftw[0].copy()))
                rec.torques.append(obs.actuator_force.copy())
            if state[0][ARM_SUB] == hold_lifted:  # weigh the load (the environment pulls down)
                weighed.append(-float(ftw[2, 2]))
            if flags & _F_LATE:
                for late in engine.timeouts[len(engine.timeouts) - int(out[2]):]:
                    self._warn_late(rec, script, late, q, target)
            nxt = self._next_tick(engine, rec, obs, target, steps >= max_steps)
            if nxt is None:
                break
            obs = nxt
            steps += 1
        return engine, obs

    def _next_tick(self, engine, rec: ExecutionRecord, obs: Observation, target: np.ndarray,
                   out_of_steps: bool) -> Observation | None:
        """The end of a control tick, shared by both loops: stop on the step limit or the script's
        stop, else drive one step towards ``target``; None when the dig ends here (a physical failure
        of the simulation is reported in ``rec``, not raised)."""
        if engine.stop is None and out_of_steps:
            engine.stop = Stop(obs.time, "timeout", step=engine.current(ARM_SUB).name)
        if engine.stop is not None:
            return None
        try:
            return self._estimate(self.sim.track(self._servo_target(target, obs)))
        except ExcavsimError as exc:
            self._failed(rec, exc)
            return None

    def _loop_reference(self, plan: DigPlan, script: Script, rec: ExecutionRecord, target: np.ndarray,
                        obs: Observation, weighed: list[float], max_steps: float,
                        announce: Callable[[str, ExecutionRecord], None]) -> tuple[ScriptEngine, Observation]:
        """The control loop in Python on :class:`ScriptEngine` (the reference for :meth:`_loop`, and
        the loop with compliance on). Returns the engine and the last observation."""
        sim = self.sim
        engine = ScriptEngine(script)
        joints = [[self._names.index(j) for j in sub.joints] for sub in script.subscripts]
        paths: list[PathFollower | None] = [None] * len(joints)  # the path each sub-script follows
        stall = _StallWatch(self.cfg, sim.torque_limit[self._arm_idx])
        steps = 0
        while True:
            if self._limits_vary:  # the relief torques at this pose
                stall.torque_limit = np.asarray(sim.torque_limit)[self._arm_idx]
            reading = self.ft.reading(obs)
            sense = Sense(obs.time, dict(zip(self._names, obs.q)), dict(zip(self._names, obs.qdot)),
                          dict(zip(self._names, obs.actuator_force)), reading.force_tip)
            seen = len(engine.transitions)
            commands = engine.tick(sense)
            for tr in engine.transitions[seen:]:
                cmd = script.subscripts[tr.subscript].steps[tr.step].command
                paths[tr.subscript] = self._lay_out(cmd, obs.q, plan, rec) if cmd.path else None
                if tr.subscript == ARM_SUB:
                    announce(tr.name, rec)
            if engine.stop is not None:  # an abort
                break
            for i, cmd in enumerate(commands):
                if cmd.path:
                    target[joints[i]] = self._follow(paths[i], obs, reading, target[joints[i]], rec)
                    engine.report(i, target[joints[i]], at_end=paths[i].at_end)
                elif cmd.targets:
                    target[joints[i]] = cmd.targets
            if paths[ARM_SUB] is not None and paths[ARM_SUB].in_cut:
                paths[ARM_SUB] = self._watch_stall(stall, paths[ARM_SUB], obs, target, rec)
            self._record(rec, obs, reading)
            if engine.current(ARM_SUB).name == "hold lifted":  # weigh the load (the environment pulls down)
                weighed.append(-float(reading.force_world[2]))
            timed_out_before = len(engine.timeouts)
            engine.end_tick(sense)
            for late in engine.timeouts[timed_out_before:]:
                self._warn_late(rec, script, late, obs.q, target)
            nxt = self._next_tick(engine, rec, obs, target, steps >= max_steps)
            if nxt is None:
                break
            obs = nxt
            steps += 1
        return engine, obs

    def _lay_out(self, cmd: Command, q: np.ndarray, plan: DigPlan, rec: ExecutionRecord) -> PathFollower:
        """The path a path command names, laid out as its step starts with the joints at ``q`` (6,)."""
        cfg = self.cfg
        tip = self.arm.forward(q[self._arm_idx])
        cut_from = math.inf
        if cmd.path == "touchdown":  # straight down over the entry at the touch pitch
            entry, tp = plan.poses[0], touch_pitch(plan, self.arm, cfg)
            path = np.array([[entry[0], entry[1] + cfg.approach_height_m, tp],
                             [entry[0], entry[1] - cfg.touch_search_m, tp]])
        elif cmd.path == "dig":
            path, cut_from = self._dig_path(plan, tip, rec)
        elif cmd.path == "lift":
            path = np.array([tip, [tip[0], max(cfg.lift_height_m, tip[1]), tip[2]]])
        elif cmd.path == "dump":  # pour: turn the bucket at a fixed tip
            path = np.array([tip, [tip[0], tip[1], math.radians(cfg.dump_pose[2])]])
        else:
            raise ConfigError(f"dig script: unknown path {cmd.path!r}; the executor lays out touchdown, dig, "
                              f"lift and dump")
        return PathFollower(path, cmd.speed, cfg.pitch_radius_m, cut_from)

    def _dig_path(self, plan: DigPlan, tip: np.ndarray, rec: ExecutionRecord) -> tuple[np.ndarray, float]:
        """At contact (the bucket tip at ``tip``): record the touch-down (§7.1.3), shift the planned path
        by its offset, and lead in to it. Returns the path and the length of its lead-in [m]."""
        cfg = self.cfg
        rec.touch_found_z = float(tip[1])
        rec.touch_offset_m = rec.touch_found_z + cfg.touch_sink_m - rec.touch_expected_z
        if abs(rec.touch_offset_m) > cfg.touch_warn_m:
            kind = "below" if rec.touch_offset_m < 0 else "above"
            rec.warnings.append(
                f"contact {100 * abs(rec.touch_offset_m):.1f} cm {kind} the map: "
                + ("the map is high, or the bucket overshot before the force registered (Fig. 104)"
                   if kind == "below" else "the map is low, or terrain interferes before the entry (Fig. 105)"))
        shifted = plan.poses.copy()
        lo, hi = plan.shift_bounds_m
        shifted[:, 1] += float(np.clip(rec.touch_offset_m, max(lo, -cfg.touch_shift_max_m),
                                       min(hi, cfg.touch_shift_max_m)))
        rec.planned_path = shifted
        # lead-in: back up clear of the soil, turn to the entry pitch in the air, go in
        clear = shifted[0, 1] + cfg.lead_in_clearance_m
        lead = np.array([tip, [tip[0], clear, tip[2]], [shifted[0, 0], clear, shifted[0, 2]]])
        return np.concatenate([lead, shifted]), path_length(np.concatenate([lead, shifted[:1]]), cfg.pitch_radius_m)

    def _follow(self, path: PathFollower, obs: Observation, reading: FTReading, held: np.ndarray,
                rec: ExecutionRecord) -> np.ndarray:
        """The joint targets one control step further along ``path`` (``held`` where IK fails); in the
        cut, compliance raises the rest of the path (its rise so far is ``rec.compliance[-1]``)."""
        pose = path.advance(self.sim.control_dt)
        if path.in_cut and self.cfg.compliance != "off":
            rise = self._yield(rec.compliance[-1] if rec.compliance else 0.0, obs, reading)
            pose = pose + np.array([0.0, rise, 0.0])
            rec.compliance.append(rise)
        q, ok = self._inverse(pose)
        return q if ok else held

    def _watch_stall(self, stall: _StallWatch, path: PathFollower, obs: Observation, target: np.ndarray,
                     rec: ExecutionRecord) -> PathFollower:
        """Log the tip along the cut; on a stall, record it, hold the arm where it is, and return the
        way back out along the path taken (else ``path``)."""
        q = obs.q[self._arm_idx]
        rec.executed_path.append(self.arm.forward(q))
        j = stall.check(obs.time, q, obs.actuator_force[self._arm_idx], target[self._arm_idx])
        if j is None:
            return path
        rec.stall = {"joint": self.machine.planar[j], "time": obs.time, "tip": self.arm.forward(q),
                     "torque": float(obs.actuator_force[self._arm_idx[j]])}
        target[self._arm_idx] = q
        return PathFollower(np.asarray(rec.executed_path)[::-1], path.speed, self.cfg.pitch_radius_m)

    def _record(self, rec: ExecutionRecord, obs: Observation, reading: FTReading) -> None:
        """Log time, the F/T force and the joint torques at the F/T sensor's rate."""
        if len(rec.times) == 0 or obs.time - rec.times[-1] >= 1.0 / self.ft.rate_hz - 1e-9:
            rec.times.append(obs.time)
            rec.ft.append((obs.time, reading.force_tip.copy()))
            rec.torques.append(obs.actuator_force.copy())

    def _warn_late(self, rec: ExecutionRecord, script: Script, late: Transition, q: np.ndarray,
                   target: np.ndarray) -> None:
        err = np.abs(q - target)
        timeout = script.subscripts[late.subscript].steps[late.step].timeout_s
        rec.warnings.append(f"step {late.name!r} did not settle within {timeout:.0f} s "
                            f"(largest joint error {np.degrees(err.max()):.1f} deg at "
                            f"{self._names[int(np.argmax(err))]}); moving on")

    @staticmethod
    def _failed(rec: ExecutionRecord, exc: ExcavsimError) -> None:
        """Record a failure of the world itself as the dig's outcome: ``diverged`` (the reason among the
        warnings), ``timeout: ...`` (the episode's wall-clock limit), or ``simulation failure: ...``."""
        if isinstance(exc, Diverged):
            rec.outcome = "diverged"
            rec.warnings.append(str(exc))
        elif isinstance(exc, OutOfTime):
            rec.outcome = f"timeout: {exc}"
        else:
            rec.outcome = f"simulation failure: {exc}"

    def _conclude(self, rec: ExecutionRecord, stop: Stop, late: bool,
                  announce: Callable[[str, ExecutionRecord], None]) -> None:
        """The outcome of a script that stopped; after an abort, park."""
        if stop.kind == "end":
            rec.outcome = "stalled" if rec.stall else ("completed late" if late else "completed")
        elif stop.kind == "timeout":
            rec.outcome = f"timeout in step {stop.step!r}"
        else:
            rec.outcome = stop.abort.outcome
            announce(rec.outcome, rec)
            rec.warnings.append(stop.abort.note)
            self._park(rec)

    def _yield(self, rise: float, obs: Observation, reading: FTReading) -> float:
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
            gain *= 1.0 + float(np.linalg.norm(reading.force_tip)) / max(v, cfg.impedance_min_speed_m_s) \
                / cfg.impedance_ref_n_s_per_m
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


class _StallWatch:
    """A stall while cutting: a planar joint at ``stall_torque_fraction`` of its relief limit that
    lags its target by more than ``stall_error_rad`` for ``stall_time_s``. Executor logic rather than
    a script condition: the dig step goes on, backing out, and the watch runs only in the cut."""

    def __init__(self, cfg: ExecutorConfig, torque_limit: np.ndarray):
        self.cfg = cfg
        self.torque_limit = torque_limit  # (3,) [N m]
        self.since: float | None = None  # since when a joint is saturated and lagging [s]

    def check(self, time: float, q: np.ndarray, torque: np.ndarray, target: np.ndarray) -> int | None:
        """The index (into ``ARM``) of the joint that stalled on this tick, or None (q, torque, target: (3,))."""
        saturated = np.abs(torque) >= self.cfg.stall_torque_fraction * self.torque_limit
        bad = saturated & (np.abs(q - target) > self.cfg.stall_error_rad)
        if not bad.any():
            self.since = None
            return None
        self.since = time if self.since is None else self.since
        return int(np.argmax(bad)) if time - self.since >= self.cfg.stall_time_s else None


_F_TICKED, _F_CUT, _F_STALL, _F_LATE, _F_STOP = 1, 2, 4, 8, 16


@numba.njit(cache=True)
def _tick_kernel(tick, prog, state, time, q, torque, ftw, target, arm_idx, ik, chain, path, cum, fs, limit, pose, out):
    """One control tick of :meth:`DigExecutor._loop` in compiled code (the reference's operations, in its order).

    With ``tick``: the engine's tick; when it made transitions or stopped, returns ``_F_TICKED`` at
    once with their number in ``out[1]`` (the caller lays out their paths and calls again without
    ``tick``). Then each sub-script's command: a path (the arm's) moves its cursor ``fs[0]`` by
    ``speed x dt`` (:meth:`PathFollower.advance`), solves IK (:func:`~excavsim.robot.fast.solve_pose`,
    as :meth:`DigExecutor._inverse`), sets the arm's ``target`` where reachable and reports it; joint
    targets are copied into ``target``. In the cut (``fs[0] >= fs[3]``) the tip pose is written to
    ``pose`` (``_F_CUT``) and the stall watch runs (:class:`_StallWatch`; ``_F_STALL`` with the joint in
    ``out[0]``). Last the engine's end of tick (``_F_LATE`` with the number of timeouts in ``out[2]``,
    ``_F_STOP`` when the script stopped).

    Args:
        q, torque: (6,) joint angles and actuator forces; ftw: (4, 3) the F/T reading
            (:meth:`~excavsim.sensing.ft.ForceSensor.reading_into`); target: (6,) the joint targets, updated.
        arm_idx: (3,) the planar joints; ik, chain: :func:`~excavsim.robot.fast.arm_params` and its
            :func:`~excavsim.robot.fast.chain_lengths`; path, cum: the arm's path and its cumulative lengths.
        fs: cursor, speed, end, cut_from, stall since (NaN: not), dt, stall fraction, error and time.
        limit: (3,) the planar joints' relief torques.
    """
    f = ftw[0]
    fnorm = math.sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2])
    if tick:
        n = engine_tick(prog, state, time, q, fnorm)
        if n > 0 or state[11][0] != 0:
            out[1] = n
            return _F_TICKED
    flags = 0
    steps, jl, subs, tg = prog[3], prog[2], prog[7], prog[5]
    index = state[0]
    for i in range(subs.shape[0]):
        g = subs[i, 0] + index[i]
        if steps[g, _S_PATH]:
            s = fs[0] + fs[1] * fs[5]
            if fs[2] < s:
                s = fs[2]
            fs[0] = s
            interp_pose(path, s, cum, pose)
            ok, q0, q1, q2 = solve_pose(ik, chain[0], chain[1], chain[2], chain[3], pose[0], pose[1], pose[2])
            if ok:
                target[arm_idx[0]] = q0
                target[arm_idx[1]] = q1
                target[arm_idx[2]] = q2
            rep = np.empty(3)
            for k in range(3):
                rep[k] = target[arm_idx[k]]
            engine_report(prog, state, i, rep, s >= fs[2])
        else:
            for k in range(steps[g, _S_TGN]):
                target[jl[subs[i, 2] + k]] = tg[steps[g, _S_TG0] + k]
    arm_path = steps[subs[0, 0] + index[0], _S_PATH]
    if arm_path and fs[0] >= fs[3]:  # in the cut: log the tip, watch for a stall
        x, z, pitch = forward_pose(ik, q[arm_idx[0]], q[arm_idx[1]], q[arm_idx[2]])
        pose[0], pose[1], pose[2] = x, z, pitch
        flags |= _F_CUT
        bad = -1
        for k in range(3):
            j = arm_idx[k]
            if abs(torque[j]) >= fs[6] * limit[k] and abs(q[j] - target[j]) > fs[7]:
                bad = k
                break
        if bad < 0:
            fs[4] = math.nan
        else:
            if math.isnan(fs[4]):
                fs[4] = time
            if time - fs[4] >= fs[8]:
                out[0] = bad
                flags |= _F_STALL
    n = engine_end_tick(prog, state, time, q, fnorm)
    if n > 0:
        out[2] = n
        flags |= _F_LATE
    if state[11][0] != 0:
        flags |= _F_STOP
    return flags
