"""One cycle of the dig-scan-plan loop (000_a3ca905d8c6d92bf.txt §7.2, Fig. 107): what ``make demo`` runs.

Scan the box with the arm parked out of view (ten calibrated, median-filtered range images), build
the elevation map, plan one dig on the map (never on the true terrain), execute it with the dig
script, let the soil settle, and scan again. The summary reports the map's accuracy, the plan, the
execution record and the soil moved, measured both on the scanned maps and (privileged) on the
true terrain. The full loop with its stopping rules, recording and campaigns is issue #7.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable

import numpy as np

from excavsim import constants
from excavsim.config import (ExecutorConfig, PlannerConfig, SensingConfig, TrenchGoal, get_soil, load_executor_config,
                             load_planner_config, load_sensing_config, load_trench_goal)
from excavsim.execution.dig import DigExecutor, DigPlan
from excavsim.planning.predictor import WedgePredictor
from excavsim.planning.trench import TrenchPlanner, goal_profile
from excavsim.robot.kinematics import PlanarArm
from excavsim.robot.reachability import load_or_build
from excavsim.sensing.elevation import build_map, map_accuracy
from excavsim.sensing.scanner import LaserScanner
from excavsim.world.simulation import Simulation


# The model's "home" keyframe: arm raised over the box in the plane of waist 0.
HOME = np.array([0.0, 1.3187, -1.9702, -0.3957, 0.0, 0.0])


def _goto(sim: Simulation, q: np.ndarray, cfg: ExecutorConfig) -> None:
    """Joint move to ``q``, waist last when leaving the box and first when coming back is not needed:
    home and park both hold the bucket high, so a straight joint move clears the walls."""
    for _ in range(int(cfg.move_timeout_s / sim.control_dt)):
        if np.all(np.abs(sim.track(q).q - q) <= cfg.settle_tol_rad):
            break


def _park(sim: Simulation, cfg: ExecutorConfig) -> None:
    _goto(sim, np.r_[np.radians(cfg.park_joints_deg), 0.0, 0.0], cfg)


def _scan(sim: Simulation, scanner: LaserScanner, cfg: SensingConfig):
    images = [scanner.scan(sim.data.time) for _ in range(cfg.map.n_scans)]
    emap, cals = build_map(images, scanner.geometry, cfg.map)
    return emap, map_accuracy(emap, sim.soil.grid.surface_z, cals)


@dataclasses.dataclass
class Rig:
    """Everything a loop needs around the Simulation: configurations, the robot's model of itself,
    the scanner, and the planner with its nominal force predictor."""

    goal: TrenchGoal
    planner_cfg: PlannerConfig
    executor_cfg: ExecutorConfig
    sensing_cfg: SensingConfig
    arm: PlanarArm
    scanner: LaserScanner
    planner: TrenchPlanner
    width: float
    capacity: float


def make_rig(sim: Simulation, *, seed: int = 0, goal: TrenchGoal | None = None,
             planner_cfg: PlannerConfig | None = None, executor_cfg: ExecutorConfig | None = None,
             sensing_cfg: SensingConfig | None = None) -> Rig:
    """Build the loop's pieces with the defaults from configs/ where none are given."""
    goal = goal or load_trench_goal(constants.TRENCHES_DIR / "straight.yaml")
    planner_cfg = planner_cfg or load_planner_config()
    sensing_cfg = sensing_cfg or load_sensing_config()
    arm = PlanarArm.from_model(sim.model)
    scanner = LaserScanner(sim.model, sim.soil.grid, sensing_cfg.scanner, np.random.default_rng((seed, 7)))
    nominal = get_soil(sim.scene.soil)
    width = float(sim.model.numeric(constants.BUCKET_WIDTH_NUMERIC).data[0])
    capacity = float(sim.model.numeric(constants.BUCKET_CAPACITY_NUMERIC).data[0])
    planner = TrenchPlanner(arm, load_or_build(arm), sim.torque_limit[1:4], width, capacity, goal, planner_cfg,
                            WedgePredictor(nominal, width), nominal.density_kg_m3)
    return Rig(goal, planner_cfg, executor_cfg or load_executor_config(), sensing_cfg, arm, scanner, planner, width,
               capacity)


def run_cycle(sim: Simulation, *, seed: int = 0, goal: TrenchGoal | None = None,
              planner_cfg: PlannerConfig | None = None, executor_cfg: ExecutorConfig | None = None,
              sensing_cfg: SensingConfig | None = None, progress: Callable[[str], None] | None = None) -> dict:
    """Scan, map, plan, dig, settle and scan again; returns a summary dict (see :func:`format_cycle`)."""
    say = progress or (lambda _s: None)
    wall0 = time.perf_counter()
    rig = make_rig(sim, seed=seed, goal=goal, planner_cfg=planner_cfg, executor_cfg=executor_cfg,
                   sensing_cfg=sensing_cfg)
    goal, executor_cfg, sensing_cfg, arm, scanner = rig.goal, rig.executor_cfg, rig.sensing_cfg, rig.arm, rig.scanner
    say("parking the arm out of the scanner's view")
    _park(sim, executor_cfg)
    say(f"scanning: {sensing_cfg.map.n_scans} range images")
    emap, acc0 = _scan(sim, scanner, sensing_cfg)
    say("  " + acc0.summary())
    width = rig.width
    plan = rig.planner.plan(emap)
    say(f"planned in {plan.seconds:.2f} s: {plan.reason}")
    heights0 = sim.soil.grid.heights.copy()
    record = None
    if plan.action is not None:
        _goto(sim, HOME, executor_cfg)  # from park back over the box
        k, a, d1, d2 = plan.action
        say(f"  dig k {k:.2f} m, alpha {math.degrees(a):.0f} deg, d1 {d1:.2f} m, d2 {d2:.2f} m: "
            f"{1000 * plan.volume_m3:.1f} l predicted")
        record = DigExecutor(sim, arm, executor_cfg).run(
            DigPlan(plan.poses, plan.phases, math.radians(goal.waist_deg), plan.volume_m3))
        say(f"executed: {record.outcome}; {1000 * record.bucket_volume_m3:.1f} l in the bucket at lift-out")
    sim.settle_soil()
    emap1, acc1 = _scan(sim, scanner, sensing_cfg)
    # soil removed from the trench's footprint in the arm plane (privileged truth)
    g = sim.soil.grid
    xs, ys = np.meshgrid(g.x0 + np.arange(g.shape[1]) * g.cell, g.y0 + np.arange(g.shape[0]) * g.cell)
    radial = np.hypot(xs, ys)
    in_trench = (np.abs(ys) <= width / 2) & (radial >= goal.near_x_m) & (radial <= goal.far_x_m)
    removed = float((heights0 - g.heights)[in_trench].sum() * g.cell_area)
    goal_vol = float(np.clip(goal.surface_z_m - goal_profile(goal, radial[in_trench]), 0, None).sum() * g.cell_area)
    return {"map_before": acc0, "map_after": acc1, "plan": plan, "record": record, "removed_m3": removed,
            "goal_m3": goal_vol, "volumes_initial": sim.soil.initial_volume, "volumes_final": sim.soil.volumes(),
            "sim_time_s": float(sim.data.time), "wall_time_s": time.perf_counter() - wall0, "emap": emap1}


def format_cycle(summary: dict) -> str:
    """A short report of :func:`run_cycle`."""
    plan, rec = summary["plan"], summary["record"]
    lines = ["", f"map before: {summary['map_before'].summary()}", f"map after:  {summary['map_after'].summary()}"]
    if plan.action is None:
        lines.append(f"no dig: {plan.reason}")
    else:
        k, a, d1, d2 = plan.action
        lines.append(f"plan: k {k:.2f} m, alpha {math.degrees(a):.0f} deg, d1 {d1:.3f} m, d2 {d2:.3f} m; "
                     f"{1000 * plan.volume_m3:.1f} l predicted; {int(plan.feasible.sum())} feasible of "
                     f"{plan.feasible.size} cells in {plan.seconds:.2f} s")
        lines.append(f"dig: {rec.outcome}; touch-down offset {100 * rec.touch_offset_m:+.1f} cm; path error "
                     f"{100 * rec.path_error():.1f} cm; {1000 * rec.bucket_volume_m3:.1f} l in the bucket")
        if rec.stall:
            lines.append(f"stall: {rec.stall['joint']} at {rec.stall['torque']:.0f} N m, tip {rec.stall['tip'].round(2)}")
        for w in rec.warnings:
            lines.append(f"warning: {w}")
        lines.append("phases: " + ", ".join(f"{n} {t:.1f} s" for n, t in rec.phase_times.items()))
    v = summary["volumes_final"]
    lines.append(f"soil removed from the trench {1000 * summary['removed_m3']:.1f} l of {1000 * summary['goal_m3']:.0f} l "
                 f"to dig; box + bucket + spoil {v.total:.9f} m^3 (change {v.total - summary['volumes_initial']:.1e})")
    lines.append(f"simulated {summary['sim_time_s']:.1f} s in {summary['wall_time_s']:.1f} s wall")
    return "\n".join(lines)
