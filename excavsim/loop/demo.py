"""The demo job: load the scene and move the arm through a scripted sequence of Cartesian poses.

Until the closed dig-scan-plan loop exists this is what ``make demo`` runs. The sequence mimics one
trenching dig in the air (above entry, penetrate, drag, curl, lift, swing to spoil, dump, return,
park), commanded the way the T3's interface works (§7.1.1: point-to-point Cartesian moves): each
move is interpolated in (x, z, pitch), solved by IK and tracked by the flow- and relief-limited
hydraulic servos. The summary reports how well MuJoCo followed the kinematic model.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence

import numpy as np
from dm_control import mjcf

from excavsim import constants
from excavsim.config import RobotConfig
from excavsim.errors import ExcavsimError
from excavsim.robot.kinematics import PlanarArm
from excavsim.robot.servo import setpoint_rates


@dataclasses.dataclass(frozen=True)
class Move:
    """One scripted move: a Cartesian tip pose in the arm plane, or a joint-space waist/pitch move.

    Attributes:
        name: label for the summary.
        waist_deg: waist angle during the move [deg].
        pose: (x [m], z [m], pitch [deg]) of the bucket tip in the arm plane.
        tip_speed_m_s: straight-line speed of the interpolated tip [m/s].
    """

    name: str
    waist_deg: float
    pose: tuple[float, float, float]
    tip_speed_m_s: float = 0.4


DEMO_MOVES: tuple[Move, ...] = (
    Move("above entry", 0.0, (2.05, 1.05, 40.0)),
    Move("penetrate", 0.0, (1.90, 0.80, 40.0), 0.25),
    Move("drag", 0.0, (1.45, 0.80, 10.0), 0.25),
    Move("curl", 0.0, (1.35, 0.95, -60.0), 0.2),
    Move("lift out", 0.0, (1.35, 1.40, -60.0)),
    Move("swing to spoil", 40.0, (1.35, 1.40, -60.0)),
    Move("dump", 40.0, (1.70, 1.60, 60.0)),
    Move("swing back", 0.0, (1.45, 1.15, 30.0)),
)


@dataclasses.dataclass
class MoveResult:
    """What happened during one move."""

    name: str
    duration_s: float
    tip_error_mm: float
    pitch_error_deg: float
    peak_torque_nm: np.ndarray


def _control_step(physics: mjcf.Physics, target: np.ndarray, *, gain: float, rate_limit: np.ndarray,
                  substeps: int) -> None:
    q = physics.named.data.qpos[list(constants.JOINTS)]
    physics.data.ctrl[:] = setpoint_rates(target, q, gain_per_s=gain, rate_limit=rate_limit)
    physics.step(substeps)
    if not np.all(np.isfinite(physics.data.qpos)):
        raise ExcavsimError(f"the simulation diverged at t = {physics.data.time:.3f} s (non-finite joint angles)")


def run_demo(physics: mjcf.Physics, robot: RobotConfig, *, moves: Sequence[Move] = DEMO_MOVES,
             settle_s: float = 1.5, progress: Callable[[str], None] | None = None) -> dict:
    """Run the scripted move sequence and measure tracking.

    Args:
        physics: the configured scene (see :func:`excavsim.world.scene.build_physics`).
        robot: the servo configuration used to build it.
        moves: the sequence; every pose must be reachable (checked before moving).
        settle_s: time allowed after each move's interpolation for the servos to settle [s].
        progress: called with a line of text after each move.

    Returns:
        A summary dict: per-move results, simulated and wall time, step rate, peak torques.

    Raises:
        ExcavsimError: a pose is unreachable, or the simulation diverges.
    """
    arm = PlanarArm.from_model(physics)
    names = list(constants.JOINTS)
    rate_limit = physics.named.model.actuator_ctrlrange[list(constants.ACTUATORS), 1]
    limits = physics.named.model.actuator_forcerange[list(constants.ACTUATORS), 1]
    dt_ctrl = 1.0 / robot.control_rate_hz
    substeps = max(1, int(round(dt_ctrl / physics.model.opt.timestep)))
    gain = robot.setpoint_gain_per_s
    tip_site = constants.BUCKET_TIP_SITE

    q_now = physics.named.data.qpos[names].copy()
    current = np.r_[np.degrees(q_now[0]), arm.forward(q_now[1:4])]
    start = current
    for mv in moves:  # check the whole interpolated path before moving
        goal = np.array([mv.pose[0], mv.pose[1], np.radians(mv.pose[2])])
        frac = np.linspace(0.0, 1.0, 101)[:, None]
        ok = arm.reachable(start[1:] + (goal - start[1:]) * frac)
        if not ok.all():
            raise ExcavsimError(f"demo move {mv.name!r}: the straight path to pose {mv.pose} (x m, z m, pitch deg) "
                                f"leaves the workspace at {100 * frac[~ok][0, 0]:.0f} % of the way")
        start = np.r_[mv.waist_deg, goal]
    results: list[MoveResult] = []
    steps = 0
    wall0 = time.perf_counter()
    for mv in moves:
        goal = np.array([mv.waist_deg, mv.pose[0], mv.pose[1], np.radians(mv.pose[2])])
        dist = np.linalg.norm(goal[1:3] - current[1:3])
        # Pitch and waist moves are paced at 30 deg/s of the interpolated target.
        n = max(1, int(np.ceil(max(dist / mv.tip_speed_m_s,
                                   abs(np.degrees(goal[3] - current[3])) / 30.0,
                                   abs(goal[0] - current[0]) / 30.0) / dt_ctrl)))
        peak = np.zeros(len(names))
        t0 = physics.data.time
        target = np.zeros(len(names))
        for i in range(1, n + 1):
            pose = current + (goal - current) * (i / n)
            q_planar, _ = arm.inverse(pose[1:])
            target = np.r_[np.radians(pose[0]), q_planar, 0.0, 0.0]
            _control_step(physics, target, gain=gain, rate_limit=rate_limit, substeps=substeps)
            steps += substeps
            peak = np.maximum(peak, np.abs(physics.named.data.actuator_force[list(constants.ACTUATORS)]))
        for _ in range(int(settle_s / dt_ctrl)):
            _control_step(physics, target, gain=gain, rate_limit=rate_limit, substeps=substeps)
            steps += substeps
            peak = np.maximum(peak, np.abs(physics.named.data.actuator_force[list(constants.ACTUATORS)]))
            settled = np.allclose(physics.named.data.qpos[names], target, atol=1e-4)
            if settled and np.max(np.abs(physics.named.data.qvel[names])) < 1e-3:
                break
        tip_mj = physics.named.data.site_xpos[tip_site]
        tip_cmd = arm.plane_to_world(np.radians(goal[0]), goal[1:3])
        q_meas = physics.named.data.qpos[names]
        pitch_meas = arm.forward(q_meas[1:4])[2]
        results.append(MoveResult(mv.name, physics.data.time - t0, 1000 * float(np.linalg.norm(tip_mj - tip_cmd)),
                                  float(np.degrees(abs(pitch_meas - goal[3]))), peak))
        if progress:
            r = results[-1]
            progress(f"  {r.name:<15} {r.duration_s:5.2f} s  tip error {r.tip_error_mm:6.2f} mm  "
                     f"pitch error {r.pitch_error_deg:5.2f} deg")
        current = goal
    wall = time.perf_counter() - wall0
    peak_all = np.max([r.peak_torque_nm for r in results], axis=0)
    return {
        "moves": results,
        "sim_time_s": float(physics.data.time),
        "wall_time_s": wall,
        "steps": steps,
        "steps_per_s": steps / wall,
        "realtime_factor": physics.data.time / wall,
        "peak_torque_nm": dict(zip(constants.ACTUATORS, peak_all)),
        "torque_limit_nm": dict(zip(constants.ACTUATORS, limits)),
        "arm": arm,
    }


def format_summary(summary: dict) -> str:
    """A human-readable summary table of :func:`run_demo`'s result."""
    arm: PlanarArm = summary["arm"]
    lines = ["", "T3 planar chain (from the compiled model):",
             f"  shoulder axis at x = {arm.shoulder_xz[0]:.3f} m, z = {arm.shoulder_xz[1]:.3f} m; "
             f"links {', '.join(f'{np.linalg.norm(v):.3f}' for v in arm.links)} m "
             "(upper arm, forearm, wrist pitch -> tip)",
             "", f"{'move':<15} {'time s':>7} {'tip err mm':>11} {'pitch err deg':>14}"]
    for r in summary["moves"]:
        lines.append(f"{r.name:<15} {r.duration_s:7.2f} {r.tip_error_mm:11.2f} {r.pitch_error_deg:14.2f}")
    lines += ["", f"{'joint':<12} {'peak torque N m':>16} {'limit N m':>10} {'ratio':>6}"]
    for name, peak in summary["peak_torque_nm"].items():
        lim = summary["torque_limit_nm"][name]
        lines.append(f"{name:<12} {peak:16.0f} {lim:10.0f} {peak / lim:6.2f}")
    lines += ["", f"simulated {summary['sim_time_s']:.1f} s in {summary['wall_time_s']:.2f} s wall "
                  f"({summary['steps']} steps, {summary['steps_per_s']:.0f} steps/s, "
                  f"real-time factor {summary['realtime_factor']:.1f}x)"]
    return "\n".join(lines)
