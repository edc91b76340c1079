"""The episode driver: the dig-scan-plan loop repeated until the trench is done (§7.2, Fig. 107).

:func:`run_episode` is the one loop of excavsim. Each cycle parks the arm, scans the box into an
elevation map, asks a :class:`~excavsim.loop.digs.DigSource` for one dig on the map (by default the
planner, falling back to the boundary-following digs of §7.2), executes it with the dig script and
lets the soil settle. The episode ends when the trench meets its tolerance on the map (at least
``done_fraction`` of the goal volume removed and no cell more than ``tolerance_m`` above the goal
profile), when the source has no dig, when the dig budget is spent, when the simulation diverged
(``diverged``: the world's watchdog saw a MuJoCo warning, a reset or a non-finite state; the dig
that saw it has outcome ``diverged``, and the world cannot be stepped any more), or when the
executor's ``episode_wall_limit_s`` of wall time has passed (``timeout``). Metrics per dig and per
episode: soil per dig (predicted, in the bucket), efficiency (bucket / capacity), over- and
under-dig against the goal on the true terrain, stalls, planning and simulated time, peak and
cumulative torques, and why the episode ended.

``excavsim trench`` runs it; ``excavsim cycle`` is an episode of one dig, ``excavsim demo`` one of
a scripted dig, and ``excavsim learn`` collects force data with an episode of random feasible digs.
An :class:`~excavsim.handoff.episode.EpisodeObserver` handed in by the caller (the Rerun recorder,
the online learner) sees every scan, plan, control step and dig.
"""

from __future__ import annotations

import math
import pathlib
import time
from collections.abc import Callable

import numpy as np

from excavsim.config import ExecutorConfig, PlannerConfig, SensingConfig, TrenchGoal
from excavsim.handoff.dig import Dig, DigPlan, ExecutionRecord
from excavsim.handoff.episode import DigMetrics, EpisodeObserver, EpisodeResult
from excavsim.handoff.goal import goal_profile
from excavsim.handoff.maps import ElevationMap
from excavsim.handoff.observation import Diverged, OutOfTime
from excavsim.loop.digs import DigSource, PlannedDigs
from excavsim.loop.rig import bucket_witness, go_home, make_rig, park, scan
from excavsim.mechanics.wedge import G_M_S2
from excavsim.planning.experience import DigExperience, failure_kind
from excavsim.robot.kinematics import PlanarArm
from excavsim.world.simulation import Simulation

MIN_USEFUL_M3 = 0.001  # a dig that brings up less than 1 l failed (the measure campaigns report)


class MapWriter(EpisodeObserver):
    """Saves every scanned elevation map as ``DIR/map_<cycle>.npz`` (for ``excavsim plan --map``)."""

    def __init__(self, directory: str | pathlib.Path):
        self.directory = pathlib.Path(directory)
        self.paths: list[pathlib.Path] = []

    def started(self, sim, rig, goal_mask, goal_z):
        self.directory.mkdir(parents=True, exist_ok=True)

    def scanned(self, index, emap, accuracy):
        path = self.directory / f"map_{index:02d}.npz"
        emap.save(path)
        self.paths.append(path)


def trench_footprint(sim: Simulation, goal: TrenchGoal, width: float) -> tuple[np.ndarray, np.ndarray]:
    """Grid samples inside the trench's footprint (mask) and the goal profile height at each sample."""
    g = sim.soil.grid
    xs, ys = np.meshgrid(g.x0 + np.arange(g.shape[1]) * g.cell, g.y0 + np.arange(g.shape[0]) * g.cell)
    w = math.radians(goal.waist_deg)
    radial = xs * math.cos(w) + ys * math.sin(w)
    lateral = -xs * math.sin(w) + ys * math.cos(w)
    mask = (np.abs(lateral) <= width / 2) & (radial >= goal.near_x_m) & (radial <= goal.far_x_m)
    return mask, goal_profile(goal, radial)


def map_done(emap: ElevationMap, goal: TrenchGoal, arm: PlanarArm, width: float, *, done_fraction: float,
             tolerance_m: float, initial_z: float) -> tuple[bool, float]:
    """Whether the trench meets its tolerance on the scanned map, and the removed fraction there."""
    x = np.linspace(goal.near_x_m, goal.far_x_m, 60)
    pts = arm.plane_to_world(math.radians(goal.waist_deg), np.stack([x, np.zeros_like(x)], axis=-1))
    z = emap.height_at(pts[:, 0], pts[:, 1])
    zg = goal_profile(goal, x)
    target = np.clip(initial_z - zg, 0, None).sum()
    removed = np.clip(initial_z - z, 0, None).clip(max=initial_z - zg).sum()
    frac = float(removed / target) if target > 0 else 1.0
    return bool(frac >= done_fraction and np.max(z - zg) <= tolerance_m), frac


def run_episode(sim: Simulation, *, seed: int = 0, goal: TrenchGoal | None = None, dig_budget: int = 20,
                done_fraction: float | None = 0.95, tolerance_m: float = 0.03,
                planner_cfg: PlannerConfig | None = None, executor_cfg: ExecutorConfig | None = None,
                sensing_cfg: SensingConfig | None = None, digs: DigSource | None = None,
                progress: Callable[[str], None] | None = None,
                observer: EpisodeObserver | None = None) -> EpisodeResult:
    """Dig the trench: scan, choose a dig, dig, settle, until done, no dig, or ``dig_budget`` digs.

    Args:
        sim: the world, as built (its seed sets the soil and the sensor noise).
        seed: the episode seed (the scanner's noise and drift).
        goal: the trench (default ``configs/trenches/straight.yaml``).
        dig_budget: the most digs.
        done_fraction, tolerance_m: the trench is done on the map when this fraction of the goal
            volume is removed and no cell is more than ``tolerance_m`` above the goal; None never
            stops early (digging for data).
        planner_cfg, executor_cfg, sensing_cfg: configurations (default: ``configs/``).
        digs: where each cycle's dig comes from (default :class:`~excavsim.loop.digs.PlannedDigs` with
            the episode's :class:`~excavsim.planning.experience.DigExperience`).
        progress: called with a line of text per scan and per dig.
        observer: sees the episode (see :class:`~excavsim.handoff.episode.EpisodeObserver`).

    Returns:
        The digs' metrics and the trench against the goal on the true terrain; ``end`` is ``done``,
        ``no_dig``, ``budget``, ``diverged`` or ``timeout`` (see the module docstring).
    """
    say = progress or (lambda _s: None)
    obs = observer or EpisodeObserver()
    source = digs or PlannedDigs(DigExperience())
    wall0 = time.perf_counter()
    rig = make_rig(sim, seed=seed, goal=goal, planner_cfg=planner_cfg, executor_cfg=executor_cfg,
                   sensing_cfg=sensing_cfg)
    goal, arm, width, capacity = rig.goal, rig.arm, rig.width, rig.capacity
    mask, z_goal = trench_footprint(sim, goal, width)
    h0 = sim.soil.grid.heights.copy()
    v0 = sim.soil.initial_volume
    metrics_list: list[DigMetrics] = []
    end, reason = "budget", f"dig budget of {dig_budget} spent"
    witness = bucket_witness(sim)
    limit_s = rig.executor_cfg.episode_wall_limit_s
    obs.started(sim, rig, mask, z_goal)
    sim.step_hooks.append(obs.stepped)
    sim.wall_deadline = wall0 + limit_s
    result = None
    try:
        for i in range(dig_budget + 1):
            if time.perf_counter() > sim.wall_deadline:
                end, reason = "timeout", f"the episode's wall-clock limit of {limit_s:g} s passed after {i} digs"
                break
            try:
                park(sim, rig)
            except (Diverged, OutOfTime) as exc:  # in the moves between digs: no dig to record
                end, reason = _world_failed(exc, f"parking after {i} digs")
                break
            scanned, acc = scan(sim, rig)
            obs.scanned(i + 1, scanned, acc)
            emap = source.belief(rig, scanned)  # the scanned map, as the executed digs corrected it
            done, frac = map_done(emap, goal, arm, width, tolerance_m=tolerance_m, initial_z=goal.surface_z_m,
                                  done_fraction=1.0 if done_fraction is None else done_fraction)
            say(f"dig {i + 1}: map {100 * frac:.0f} % of the goal removed (map RMS {100 * acc.rms_m:.1f} cm)")
            if done and done_fraction is not None:
                end = "done"
                reason = (f"trench done on the map: {100 * frac:.0f} % removed, every cell within "
                          f"{100 * tolerance_m:.0f} cm")
                break
            if i == dig_budget:  # the last scan only checks whether the budget's digs finished the trench
                break
            choice = source.choose(rig, emap)
            if choice.plan is not None or choice.dig is not None:
                obs.planned(i + 1, choice.plan, choice.dig)
            dig = choice.dig
            if dig is None:
                end, reason = "no_dig", choice.reason
                break
            if choice.note:
                say(choice.note)
            try:
                go_home(sim, rig)
            except (Diverged, OutOfTime) as exc:
                end, reason = _world_failed(exc, f"going home for dig {i + 1}")
                break
            t0 = sim.time
            clearance = float(np.min(dig.poses[:, 1] - goal_profile(goal, dig.poses[:, 0])))
            bounds = (-max(clearance, 0.0), math.inf if dig.shift_up else 0.0)
            plan = DigPlan(dig.poses, dig.phases, math.radians(goal.waist_deg), dig.volume_m3, bounds,
                           surface=rig.planner.surface(emap))
            rec = rig.executor.run(plan, on_phase=witness)
            sim.settle_soil()
            metrics = dig_metrics(i + 1, dig, rec, capacity=capacity, sim_s=float(sim.time - t0),
                                  ft_rate_hz=rig.executor.ft.rate_hz, density_kg_m3=rig.planner.density)
            metrics_list.append(metrics)
            obs.dug(i + 1, rec, metrics)
            say(f"  {dig.kind} {rec.outcome}: {1000 * dig.volume_m3:.1f} l planned, "
                f"{1000 * rec.bucket_volume_m3:.1f} l dug"
                + (f", stall at {metrics.stall_joint}" if metrics.stall_joint else ""))
            if rec.outcome == "diverged" or rec.outcome.startswith("timeout: "):  # the world cannot go on
                why = rec.warnings[-1] if rec.outcome == "diverged" else rec.outcome[len("timeout: "):]
                end = "diverged" if rec.outcome == "diverged" else "timeout"
                reason = f"{why} (dig {i + 1})"
                break
            lesson = source.learned(rig, i + 1, dig, rec, emap)
            if lesson:
                say(lesson)
        result = episode_result(sim, metrics_list, end, reason, mask=mask, z_goal=z_goal, h0=h0, v0=v0,
                                wall_s=time.perf_counter() - wall0)
        return result
    finally:
        sim.wall_deadline = None
        sim.step_hooks.remove(obs.stepped)
        obs.finished(result)


def _world_failed(exc: Diverged | OutOfTime, where: str) -> tuple[str, str]:
    """The episode's end and reason when the world failed outside a dig (``where``: what the loop was doing)."""
    return ("diverged" if isinstance(exc, Diverged) else "timeout"), f"{exc} ({where})"


def dig_metrics(index: int, dig: Dig, rec: ExecutionRecord, *, capacity: float, sim_s: float,
                ft_rate_hz: float, density_kg_m3: float) -> DigMetrics:
    """One dig's metrics. Torques cover the soil-loaded part of the dig (touch-down to the end of the
    lift-out): the moves through the air to the spoil and back are the servo's business, not the dig's."""
    lo, hi = rec.in_soil_window()
    tt = np.asarray(rec.times)
    sel = (tt >= lo) & (tt <= hi) if rec.torques else np.zeros(0, bool)
    torques = np.asarray(rec.torques)[sel] if sel.any() else np.zeros((1, 6))
    dt = 1.0 / ft_rate_hz
    weighed = rec.lifted_load_n / (density_kg_m3 * G_M_S2) if math.isfinite(rec.lifted_load_n) else 0.0
    return DigMetrics(
        index=index, kind=dig.kind, action=dig.action, outcome=rec.outcome, predicted_m3=dig.volume_m3,
        bucket_m3=rec.bucket_volume_m3, efficiency=rec.bucket_volume_m3 / capacity,
        stall_joint=rec.stall["joint"] if rec.stall else None, planning_s=dig.planning_s,
        sim_s=sim_s, peak_torque_nm=np.abs(torques).max(axis=0),
        cumulative_torque_nm_s=float(np.abs(torques).sum() * dt), predicted_peak_nm=dig.predicted_peak_nm,
        weighed_m3=float(weighed),
        failure=failure_kind(rec, weighed, MIN_USEFUL_M3))


def episode_result(sim: Simulation, digs: list[DigMetrics], end: str, reason: str, *, mask: np.ndarray,
                   z_goal: np.ndarray, h0: np.ndarray, v0: float, wall_s: float) -> EpisodeResult:
    """The trench against the goal on the true terrain (privileged), and the episode's totals."""
    h = sim.soil.grid.heights
    cell = sim.soil.grid.cell_area
    removed = float(np.clip(h0 - h, 0, None)[mask].sum() * cell)
    goal_m3 = float(np.clip(h0 - z_goal, 0, None)[mask].sum() * cell)
    over = np.append(np.clip(z_goal - h, 0, None)[mask], 0.0)  # below the goal profile (0 if off the box)
    under = np.append(np.clip(h - z_goal, 0, None)[mask], 0.0)  # soil still above it
    return EpisodeResult(
        digs=digs, end=end, reason=reason, goal_m3=goal_m3, removed_m3=removed, overdig_max_m=float(over.max()),
        overdig_rms_m=float(np.sqrt(np.mean(over[:-1] ** 2))) if over.size > 1 else 0.0,
        underdig_max_m=float(under.max()),
        underdig_rms_m=float(np.sqrt(np.mean(under[:-1] ** 2))) if under.size > 1 else 0.0,
        sim_time_s=sim.time, wall_time_s=wall_s, volume_change_m3=sim.soil.volumes().total - v0)
