"""Joint-space scripts for the loading machines: a planned tip path turned into timed servo set-points.

A loading dig (Singh 1995 §3.5, Fig. 26) is executed as one parameterized script in the
sense of Rowe 1997 §4: its numbers (the set-points and their times) are recomputed for
every dig from the plan, and each joint follows its own sub-script. Here the sub-scripts are the
joint-space path the machine's inverse kinematics (:mod:`excavsim.robot.loaders`) gives for the sampled
tip poses of the plan, timed so that the tip moves at ``tip_speed`` and no joint exceeds its speed
limit (:func:`timed_path`); transfers between poses (to the dig, to the truck and back) are straight
joint-space moves at the joint speed limits (:func:`joint_move`). :func:`play_script` plays a script through a
servo callable and then holds the last set-point until the joints arrive or a timeout passes.

Simplified (stated): the script is open loop in time (no force conditions, no touch-down, no
compliance); a stall shows only as the tracking error, which :class:`ScriptResult` reports.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from excavsim.errors import ConfigError


@dataclasses.dataclass(frozen=True)
class JointScript:
    """Set-points ``targets`` (N, n) at times ``times`` (N,) [s, from the script's start], linear in between."""

    times: np.ndarray
    targets: np.ndarray
    name: str = ""

    def __post_init__(self):
        t, q = np.asarray(self.times, float), np.asarray(self.targets, float)
        if t.ndim != 1 or q.ndim != 2 or q.shape[0] != t.size or t.size < 1 or np.any(np.diff(t) < 0):
            raise ConfigError(f"a joint script needs N non-decreasing times and (N, n) targets; given "
                              f"{t.shape} and {q.shape}")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(q))):
            raise ConfigError("a joint script's times and targets must be finite")

    @property
    def duration(self) -> float:
        return float(self.times[-1])

    def at(self, t: float) -> np.ndarray:
        """The set-points (n,) at time ``t`` [s] (held at the ends)."""
        return np.array([np.interp(t, self.times, self.targets[:, j]) for j in range(self.targets.shape[1])])


def timed_path(q: np.ndarray, tip_xz: np.ndarray, *, tip_speed: float, joint_speed: np.ndarray,
               name: str = "") -> JointScript:
    """A script through joint values ``q`` (N, n) whose tip points are ``tip_xz`` (N, 2) [m]: each segment takes
    the longer of its tip length over ``tip_speed`` [m/s] and its largest joint step over ``joint_speed`` (n,)."""
    q = np.asarray(q, float)
    tip = np.asarray(tip_xz, float)
    if q.ndim != 2 or tip.shape != (q.shape[0], 2) or not tip_speed > 0 or np.any(np.asarray(joint_speed) <= 0):
        raise ConfigError("timed_path: q (N, n), tip (N, 2), tip_speed > 0 and joint speeds > 0 are required")
    dt_tip = np.hypot(*np.diff(tip, axis=0).T) / tip_speed
    dt_joint = np.max(np.abs(np.diff(q, axis=0)) / np.asarray(joint_speed, float), axis=1)
    return JointScript(np.concatenate([[0.0], np.cumsum(np.maximum(dt_tip, dt_joint))]), q, name)


def joint_move(q0: np.ndarray, q1: np.ndarray, *, joint_speed: np.ndarray, name: str = "") -> JointScript:
    """A straight joint-space move from ``q0`` to ``q1`` (n,), as fast as the slowest joint allows."""
    q0, q1 = np.asarray(q0, float), np.asarray(q1, float)
    t = float(np.max(np.abs(q1 - q0) / np.asarray(joint_speed, float)))
    return JointScript(np.array([0.0, max(t, 1e-9)]), np.stack([q0, q1]), name)


@dataclasses.dataclass
class ScriptResult:
    """How a script went: control steps taken, the largest tracking error while it ran and at its end."""

    name: str
    steps: int
    max_error: float
    final_error: float
    arrived: bool


def play_script(step: Callable[[np.ndarray], np.ndarray], q_now: np.ndarray, script: JointScript, dt: float, *,
                tolerance: np.ndarray, hold_timeout_s: float = 3.0) -> tuple[ScriptResult, np.ndarray]:
    """Play ``script`` through the servo callable ``step(target) -> encoders`` every ``dt`` [s], then hold its last
    set-point until every joint is within ``tolerance`` (n,) or ``hold_timeout_s`` passes.

    Returns:
        The result and the encoders at the end.
    """
    q = np.asarray(q_now, float)
    n_run = int(np.ceil(script.duration / dt))
    worst, steps = 0.0, 0
    scale = np.asarray(tolerance, float)
    for i in range(1, n_run + 1):
        target = script.at(i * dt)
        q = step(target)
        steps += 1
        worst = max(worst, float(np.max(np.abs(q - target) / scale)))
    last = script.targets[-1]
    arrived = bool(np.all(np.abs(q - last) <= scale))
    for _ in range(int(hold_timeout_s / dt)):
        if arrived:
            break
        q = step(last)
        steps += 1
        arrived = bool(np.all(np.abs(q - last) <= scale))
    return ScriptResult(script.name, steps, worst, float(np.max(np.abs(q - last) / scale)), arrived), q
