"""Running Rowe's script on a machine's servos, tick by tick (Rowe 1997 §4.3).

:func:`run_script` runs a script whose commands are all joint targets on any
:class:`~excavsim.handoff.observation.Servos` (the T3's Simulation and the excavators' worlds are ones): each
control tick the engine reads the sensed joints and the script's targets go to the servos. On a machine
with a :class:`~excavsim.execution.rowe_script.timing.SwingProfile`, the swing's command goes through it
(its set-point eases towards the script's; the other joints get the script's commands as steps, as Rowe's
PD controller did, §4.0). :func:`approach` moves a machine to a pose the same way.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from excavsim.errors import UsageError
from excavsim.execution.conditions import Sense
from excavsim.execution.rowe_script.listing import ScriptJoints
from excavsim.execution.rowe_script.timing import SwingProfile, SwingTracker
from excavsim.execution.script import Script, ScriptEngine, Transition
from excavsim.handoff.observation import HydraulicServos, Observation, Servos


@dataclasses.dataclass
class ScriptRun:
    """What a script did: its start and stop time [s], how it stopped ("end" or "timeout"), every step
    change, and the sensed joint angles [rad] (by joint name) on the tick each step started."""

    start: float
    stop: float
    outcome: str
    transitions: list[Transition]
    angles: dict[str, dict[str, float]] = dataclasses.field(default_factory=dict)

    @property
    def duration(self) -> float:
        """How long the script ran [s]."""
        return self.stop - self.start

    def phase_starts(self) -> dict[str, float]:
        """When each step started, relative to the script's start [s]."""
        return {tr.name: tr.time - self.start for tr in self.transitions}

    def angle_at(self, step: str, joint: str) -> float:
        """``joint``'s sensed angle [rad] on the tick ``step`` started (nan if it never started)."""
        return float(self.angles.get(step, {}).get(joint, math.nan))


def _sense(time: float, names: list[str], obs: Observation) -> Sense:
    return Sense(time, dict(zip(names, obs.q)), dict(zip(names, obs.qdot)),
                 dict(zip(names, obs.actuator_force)), np.asarray(obs.ft_force))


def run_script(servos: Servos, script: Script, joints: ScriptJoints, *, profile: SwingProfile | None = None,
               tick_clock: bool = False) -> ScriptRun:
    """Run ``script`` (joint-target commands only) tick by tick on ``servos`` until it ends or times out.

    Args:
        servos: the machine; its arrays in ``joints.order``.
        script: the script.
        joints: the machine's joints.
        profile: the swing's set-point profile (None: the swing's command as a step, as the others').
        tick_clock: time the script by counting control periods from 0 [s] (the 25 t's account of a pass)
            instead of by the servos' clock.

    Raises:
        UsageError: a step follows a Cartesian path.
    """
    for sub in script.subscripts:
        for st in sub.steps:
            if st.command.path:
                raise UsageError(f"run_script: step {st.name!r} follows a path; joint targets only")
    engine = ScriptEngine(script)
    names = list(joints.order)
    obs = servos.observe()
    target = np.array(obs.q, dtype=float)
    i_swing = names.index(joints.swing)
    tracker = None if profile is None else SwingTracker(profile, target[i_swing])
    dt = servos.control_dt
    start = t = 0.0 if tick_clock else obs.time
    limit = script.timeout_s or math.inf
    angles: dict[str, dict[str, float]] = {}
    seen = 0
    while True:
        sense = _sense(t, names, obs)
        commands = engine.tick(sense)
        for sub, cmd in zip(script.subscripts, commands):
            for j, v in zip(sub.joints, cmd.targets):
                target[names.index(j)] = v
        engine.end_tick(sense)
        for tr in engine.transitions[seen:]:
            angles.setdefault(tr.name, sense.q)
        seen = len(engine.transitions)
        if engine.stop is not None:
            return ScriptRun(start, t, engine.stop.kind, list(engine.transitions), angles)
        if t - start > limit + 1.0:  # a clock that stalls cannot hold the script forever
            return ScriptRun(start, t, "timeout", list(engine.transitions), angles)
        command = target
        if tracker is not None:
            command = target.copy()
            command[i_swing] = tracker.next(target[i_swing], dt, float(obs.q[i_swing]))
        obs = servos.track(command)
        t = t + dt if tick_clock else obs.time


def approach(servos: HydraulicServos, target: np.ndarray, profile: SwingProfile, *, swing: int = 0,
             tol: float = 0.03, timeout_s: float = 20.0) -> float:
    """Move to joint angles ``target`` [rad] (the swing, index ``swing`` of the servos' arrays, through
    ``profile``) until every joint is within ``tol`` [rad]; returns the time it took [s]."""
    q = servos.joint_angles()
    tracker = SwingTracker(profile, q[swing])
    dt, t = servos.control_dt, 0.0
    target = np.asarray(target, float)
    while t < timeout_s and np.max(np.abs(q - target)) > tol:
        cmd = target.copy()
        cmd[swing] = tracker.next(target[swing], dt, float(q[swing]))
        q = servos.step(cmd)
        t += dt
    return t
