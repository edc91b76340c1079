"""The demo job: one hand-written dig into flat sand, a dump to spoil, and the soil settling.

Until the closed dig-scan-plan loop exists this is what ``make demo`` runs. The dig is a fixed
sequence of tip waypoints (above entry, touch the surface, penetrate at alpha = 40 deg with rake
alpha + epsilon = 50 deg, drag 0.4 m while the rake falls to 30 deg, curl, lift out, swing to the
spoil side, dump, swing back), commanded the way the T3's interface works (§7.1.1: point-to-point
Cartesian moves): each move is interpolated in (x, z, pitch), turned into joint targets by IK every
control tick and tracked by the flow- and relief-limited hydraulic servos, in the
:class:`~excavsim.world.simulation.Simulation` so the soil is cut and pushes back. The summary
reports the volume dug and dumped, the soil volume balance, the peak soil force and the peak joint
torques, and how well MuJoCo followed the kinematic model.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence

import numpy as np

from excavsim import constants
from excavsim.errors import ExcavsimError
from excavsim.robot.kinematics import PlanarArm
from excavsim.world.simulation import Simulation


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


# The soil surface starts at z = 0.5 m (configs/scene.yaml). Entry at x = 2.2 m; the penetration runs
# 0.2 m at alpha = 40 deg down to 12.9 cm deep, the drag 0.4 m at that depth.
DEMO_MOVES: tuple[Move, ...] = (
    Move("above entry", 0.0, (2.20, 0.75, 50.0)),
    Move("touch surface", 0.0, (2.20, 0.51, 50.0), 0.2),
    Move("penetrate", 0.0, (2.047, 0.371, 50.0), 0.15),
    Move("drag", 0.0, (1.65, 0.371, 30.0), 0.15),
    Move("curl", 0.0, (1.60, 0.60, -30.0), 0.15),
    Move("lift out", 0.0, (1.60, 1.10, -30.0)),
    Move("swing to spoil", 40.0, (1.60, 1.10, -30.0)),
    Move("dump", 40.0, (1.70, 1.30, 100.0)),
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
    peak_soil_force_n: float
    load_m3: float


def run_demo(sim: Simulation, *, moves: Sequence[Move] = DEMO_MOVES, settle_s: float = 1.5,
             progress: Callable[[str], None] | None = None) -> dict:
    """Run the scripted dig in the simulation and measure what happened.

    Args:
        sim: the world (see :class:`~excavsim.world.simulation.Simulation`).
        moves: the sequence; every pose must be reachable (checked before moving).
        settle_s: time allowed after each move's interpolation for the servos to settle [s].
        progress: called with a line of text after each move.

    Returns:
        A summary dict: per-move results, simulated and wall time, step rate, peak torques, soil
        volumes (initial, dug, dumped, final balance) and the peak soil force.

    Raises:
        ExcavsimError: a pose is unreachable, or the simulation diverges.
    """
    arm = PlanarArm.from_model(sim.model)
    names = list(constants.JOINTS)
    dt_ctrl = sim.control_dt
    tip_site = sim.model.site(constants.BUCKET_TIP_SITE).id

    q_now = sim.observe().q
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
    v0 = sim.soil.volumes()
    results: list[MoveResult] = []
    steps = 0
    cut_total = 0.0
    poured_total = 0.0
    wall0 = time.perf_counter()

    def tick(target: np.ndarray, peak: np.ndarray, peak_force: list[float]) -> None:
        nonlocal steps, cut_total, poured_total
        obs = sim.track(target)
        steps += sim.substeps
        np.maximum(peak, np.abs(obs.actuator_force), out=peak)
        c = sim.contact
        if c is not None:
            cut_total += c.cut_volume_m3
            poured_total += c.poured_volume_m3
            peak_force[0] = max(peak_force[0], float(np.linalg.norm(c.force - c.load_weight)))

    for mv in moves:
        goal = np.array([mv.waist_deg, mv.pose[0], mv.pose[1], np.radians(mv.pose[2])])
        dist = np.linalg.norm(goal[1:3] - current[1:3])
        # Pitch and waist moves are paced at 30 deg/s of the interpolated target.
        n = max(1, int(np.ceil(max(dist / mv.tip_speed_m_s,
                                   abs(np.degrees(goal[3] - current[3])) / 30.0,
                                   abs(goal[0] - current[0]) / 30.0) / dt_ctrl)))
        peak = np.zeros(len(names))
        peak_force = [0.0]
        t0 = sim.data.time
        target = np.zeros(len(names))
        for i in range(1, n + 1):
            pose = current + (goal - current) * (i / n)
            q_planar, _ = arm.inverse(pose[1:])
            target = np.r_[np.radians(pose[0]), q_planar, 0.0, 0.0]
            tick(target, peak, peak_force)
        for _ in range(int(settle_s / dt_ctrl)):
            tick(target, peak, peak_force)
            obs = sim.observe()
            if np.allclose(obs.q, target, atol=1e-4) and np.max(np.abs(obs.qdot)) < 1e-3:
                break
        tip_mj = sim.data.site_xpos[tip_site]
        tip_cmd = arm.plane_to_world(np.radians(goal[0]), goal[1:3])
        q_meas = sim.observe().q
        pitch_meas = arm.forward(q_meas[1:4])[2]
        results.append(MoveResult(mv.name, sim.data.time - t0, 1000 * float(np.linalg.norm(tip_mj - tip_cmd)),
                                  float(np.degrees(abs(pitch_meas - goal[3]))), peak, peak_force[0],
                                  sim.soil.load))
        if progress:
            r = results[-1]
            progress(f"  {r.name:<15} {r.duration_s:5.2f} s  tip error {r.tip_error_mm:6.2f} mm  "
                     f"soil force {r.peak_soil_force_n:6.0f} N  load {1000 * r.load_m3:5.1f} l")
        current = goal
    settle = sim.soil.settle_all()
    wall = time.perf_counter() - wall0
    v1 = sim.soil.volumes()
    peak_all = np.max([r.peak_torque_nm for r in results], axis=0)
    return {
        "moves": results,
        "sim_time_s": float(sim.data.time),
        "wall_time_s": wall,
        "steps": steps,
        "steps_per_s": steps / wall,
        "realtime_factor": sim.data.time / wall,
        "peak_torque_nm": dict(zip(constants.ACTUATORS, peak_all)),
        "torque_limit_nm": dict(zip(constants.ACTUATORS, sim.torque_limit)),
        "peak_soil_force_n": max(r.peak_soil_force_n for r in results),
        "dug_m3": cut_total,
        "dumped_m3": poured_total,
        "peak_load_m3": max(r.load_m3 for r in results),
        "volumes_initial": v0,
        "volumes_final": v1,
        "settle": settle,
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
    v0, v1 = summary["volumes_initial"], summary["volumes_final"]
    lines += ["", f"soil dug {1000 * summary['dug_m3']:.1f} l (peak load {1000 * summary['peak_load_m3']:.1f} l), "
                  f"dumped {1000 * summary['dumped_m3']:.1f} l; peak soil force {summary['peak_soil_force_n']:.0f} N; "
                  f"peak wrist torque {summary['peak_torque_nm']['wrist_pitch']:.0f} N m",
              f"soil volume box + bucket + spoil: {v0.total:.9f} -> {v1.total:.9f} m^3 "
              f"(change {v1.total - v0.total:.2e}); final settle {summary['settle'].iterations} sweeps"]
    lines += ["", f"simulated {summary['sim_time_s']:.1f} s in {summary['wall_time_s']:.2f} s wall "
                  f"({summary['steps']} steps, {summary['steps_per_s']:.0f} steps/s, "
                  f"real-time factor {summary['realtime_factor']:.1f}x)"]
    return "\n".join(lines)
