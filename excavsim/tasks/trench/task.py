"""Trenching (Singh 1995 §7.2, Fig. 107): the T3 digs a trench goal out of its soil box, as a task of the platform.

:class:`TrenchTask` is what trenching supplies to the platform's :class:`~excavsim.loop.episode.Episode`:
each cycle it parks the arm out of the scanner's view, scans the box into an elevation map, asks a
:class:`~excavsim.loop.digs.DigSource` for one dig on the map (by default the planner, falling back
to the boundary-following digs of §7.2: :class:`~excavsim.tasks.trench.digs.PlannedDigs`), executes
it with the dig script and lets the soil settle. It is done when the trench meets its tolerance on
the map (at least ``done_fraction`` of the goal volume removed and no cell more than
``tolerance_m`` above the goal profile); the executor's ``episode_wall_limit_s`` of wall time is the
episode's limit (``timeout``). Metrics per dig and per episode: soil per dig (predicted, in the
bucket), efficiency (bucket / capacity), over- and under-dig against the goal on the true terrain,
stalls, planning and simulated time, peak and cumulative torques, and why the episode ended.

:func:`run_episode` cycles one to its end. ``excavsim trench`` runs it; ``excavsim cycle`` is an
episode of one dig, ``excavsim demo`` one of a scripted dig (:mod:`~excavsim.tasks.trench.demo`),
and ``excavsim learn`` collects force data with an episode of random feasible digs.
:func:`summary`, :func:`dig_rows` and :func:`format_run` are the task's campaign row, per-dig rows
and table (the platform's catalog, :mod:`excavsim.loop.catalog`, names them).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from excavsim.config import ExecutorConfig, PlannerConfig, RobotConfig, SceneConfig, SensingConfig, TrenchGoal
from excavsim.handoff.dig import Dig, DigPlan, ExecutionRecord
from excavsim.handoff.episode import DigMetrics, EpisodeObserver, EpisodeResult
from excavsim.handoff.goal import goal_profile
from excavsim.handoff.maps import ElevationMap
from excavsim.handoff.observation import Diverged, OutOfTime
from excavsim.loop.digs import Choice, DigSource
from excavsim.loop.episode import Episode, world_failed
from excavsim.rig.measures import episode_result, trench_footprint
from excavsim.rig.core import bucket_witness, go_home, make_rig, park, scan
from excavsim.mechanics.wedge import G_M_S2
from excavsim.planning.experience import DigExperience, failure_kind
from excavsim.robot.kinematics import PlanarArm
from excavsim.tasks.trench.digs import PlannedDigs
from excavsim.robot.machine import get_machine
from excavsim.world.machines import make_world
from excavsim.world.simulation import Simulation

MIN_USEFUL_M3 = 0.001  # a dig that brings up less than 1 l failed (the measure campaigns report)


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



class TrenchTask:
    """Trenching (§7.2, Fig. 107): the T3 digs a trench goal out of its soil box, or a hydraulic excavator
    (``machine``: ``tb035``, ``excavator_25t``) out of its pit, in the same loop.

    Its world is a :class:`~excavsim.world.simulation.Simulation`, its pieces the loop's
    :class:`~excavsim.rig.core.Rig`; it parks the arm out of the scanner's view before each scan,
    is done when the map shows the trench within tolerance, takes its digs from a
    :class:`~excavsim.loop.digs.DigSource` (the planner by default), executes them with the dig
    script and measures them (:class:`~excavsim.handoff.episode.DigMetrics`); its result is an
    :class:`~excavsim.handoff.episode.EpisodeResult`.

    Args:
        goal: the trench (default ``configs/trenches/straight.yaml``).
        done_fraction, tolerance_m: the trench is done on the map when ``done_fraction`` of the goal
            volume is removed and no cell is more than ``tolerance_m`` above the goal profile (None
            never stops early: digging for data).
        planner_cfg, executor_cfg, sensing_cfg, robot_cfg, scene_cfg: configurations (default
            ``configs/``), the world's used when :meth:`reset` is given none.
        machine: the trenching machine (:mod:`excavsim.robot.machine`; default the T3): its world
            (:func:`~excavsim.world.machines.make_world`) and the rig on its joints, planar chain, reach and
            torque limits (:func:`~excavsim.rig.core.make_rig`). The configurations and the goal must be the
            machine's (:class:`~excavsim.tasks.trench.spec.TrenchResolved` merges ``configs/machines/<machine>.yaml``).
    """

    final_scan = True

    def __init__(self, *, goal: TrenchGoal | None = None, done_fraction: float | None = 0.95,
                 tolerance_m: float = 0.03, planner_cfg: PlannerConfig | None = None,
                 executor_cfg: ExecutorConfig | None = None, sensing_cfg: SensingConfig | None = None,
                 robot_cfg: RobotConfig | None = None, scene_cfg: SceneConfig | None = None, machine: str = "t3"):
        self.goal, self.done_fraction, self.tolerance_m = goal, done_fraction, tolerance_m
        self.planner_cfg, self.executor_cfg, self.sensing_cfg = planner_cfg, executor_cfg, sensing_cfg
        self.robot_cfg, self.scene_cfg = robot_cfg, scene_cfg
        self.machine = get_machine(machine)
        self.wall_limit_s = math.inf

    def reset(self, seed: int, world: Simulation | None = None, digs: DigSource | None = None) -> tuple:
        sim = world if world is not None else make_world(self.machine.name, self.robot_cfg, self.scene_cfg, seed=seed)
        self.sim = sim
        self.source = digs or PlannedDigs(DigExperience())
        self.rig = rig = make_rig(sim, seed=seed, goal=self.goal, planner_cfg=self.planner_cfg,
                                  executor_cfg=self.executor_cfg, sensing_cfg=self.sensing_cfg, machine=self.machine)
        self.wall_limit_s = rig.executor_cfg.episode_wall_limit_s
        self.mask, self.z_goal = trench_footprint(sim, rig.goal, rig.width)
        self._h0 = sim.soil.grid.heights.copy()
        self._v0 = sim.soil.initial_volume
        self.metrics: list[DigMetrics] = []
        self.record: ExecutionRecord | None = None  # the last dig's
        self.emap: ElevationMap | None = None  # the map the source believes, this cycle
        self.accuracy = None
        self._witness = bucket_witness(sim)
        return sim, rig, self.mask, self.z_goal

    def budget_reason(self, budget: int) -> str:
        return f"dig budget of {budget} spent"

    def park(self) -> None:
        park(self.sim, self.rig)

    def scan(self) -> tuple[ElevationMap, Any]:
        scanned, self.accuracy = scan(self.sim, self.rig)
        return scanned, self.accuracy

    def assess(self, index, scanned, say):
        rig, goal, fraction = self.rig, self.rig.goal, self.done_fraction
        self.emap = emap = self.source.belief(rig, scanned)  # the scanned map, as the executed digs corrected it
        done, frac = map_done(emap, goal, rig.arm, rig.width, tolerance_m=self.tolerance_m,
                              initial_z=goal.surface_z_m, done_fraction=1.0 if fraction is None else fraction)
        say(f"dig {index}: map {100 * frac:.0f} % of the goal removed (map RMS {100 * self.accuracy.rms_m:.1f} cm)")
        if done and fraction is not None:
            return emap, ("done", f"trench done on the map: {100 * frac:.0f} % removed, every cell within "
                                  f"{100 * self.tolerance_m:.0f} cm")
        return emap, None

    def choose(self, emap) -> Choice:
        return self.source.choose(self.rig, emap)

    def execute(self, index, choice):
        sim, rig, goal, dig = self.sim, self.rig, self.rig.goal, choice.dig
        try:
            go_home(sim, rig)
        except (Diverged, OutOfTime) as exc:
            return None, world_failed(exc, f"going home for dig {index}")
        t0 = sim.time
        clearance = float(np.min(dig.poses[:, 1] - goal_profile(goal, dig.poses[:, 0])))
        bounds = (-max(clearance, 0.0), math.inf if dig.shift_up else 0.0)
        plan = DigPlan(dig.poses, dig.phases, math.radians(goal.waist_deg), dig.volume_m3, bounds,
                       surface=rig.planner.surface(self.emap))
        self.record = rec = rig.executor.run(plan, on_phase=self._witness)
        sim.settle_soil()
        metrics = dig_metrics(index, dig, rec, capacity=rig.capacity, sim_s=float(sim.time - t0),
                              ft_rate_hz=rig.executor.ft.rate_hz, density_kg_m3=rig.planner.density)
        self.metrics.append(metrics)
        return (rec, metrics), None

    def after(self, index, choice, dug, say):
        rec, metrics = dug
        dig = choice.dig
        say(f"  {dig.kind} {rec.outcome}: {1000 * dig.volume_m3:.1f} l planned, "
            f"{1000 * rec.bucket_volume_m3:.1f} l dug" + (f", stall at {metrics.stall_joint}" if metrics.stall_joint else ""))
        if rec.outcome == "diverged" or rec.outcome.startswith("timeout: "):  # the world cannot go on
            why = rec.warnings[-1] if rec.outcome == "diverged" else rec.outcome[len("timeout: "):]
            return ("diverged" if rec.outcome == "diverged" else "timeout"), f"{why} (dig {index})"
        lesson = self.source.learned(self.rig, index, dig, rec, self.emap)
        if lesson:
            say(lesson)
        return None

    def result(self, end, reason, wall_s) -> EpisodeResult:
        res = episode_result(self.sim, self.metrics, end, reason, mask=self.mask, z_goal=self.z_goal,
                             h0=self._h0, v0=self._v0, wall_s=wall_s)
        return dataclasses.replace(res, task="trench")



def run_episode(sim: Simulation, *, seed: int = 0, goal: TrenchGoal | None = None, dig_budget: int = 20,
                done_fraction: float | None = 0.95, tolerance_m: float = 0.03,
                planner_cfg: PlannerConfig | None = None, executor_cfg: ExecutorConfig | None = None,
                sensing_cfg: SensingConfig | None = None, digs: DigSource | None = None,
                progress: Callable[[str], None] | None = None,
                observer: EpisodeObserver | None = None) -> EpisodeResult:
    """Dig the trench: scan, choose a dig, dig, settle, until done, no dig, or ``dig_budget`` digs
    (an :class:`Episode` cycled to its end).

    Args:
        sim: the world, as built (its seed sets the soil and the sensor noise).
        seed: the episode seed (the scanner's noise and drift).
        digs: where each cycle's dig comes from (default :class:`~excavsim.tasks.trench.digs.PlannedDigs` with
            the episode's :class:`~excavsim.planning.experience.DigExperience`).
        goal, dig_budget, done_fraction, tolerance_m, planner_cfg, executor_cfg, sensing_cfg, progress, observer:
            see :class:`TrenchTask` and :class:`~excavsim.loop.episode.Episode`.

    Returns:
        The digs' metrics and the trench against the goal on the true terrain; ``end`` is ``done``,
        ``no_dig``, ``budget``, ``diverged`` or ``timeout`` (see the module docstring of :mod:`excavsim.loop.episode`).
    """
    task = TrenchTask(goal=goal, done_fraction=done_fraction, tolerance_m=tolerance_m, planner_cfg=planner_cfg,
                      executor_cfg=executor_cfg, sensing_cfg=sensing_cfg)
    episode = Episode(task, dig_budget=dig_budget, progress=progress, observer=observer)
    episode.reset(seed, sim=sim, digs=digs)
    return episode.run()



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



# -- what the platform's specification, campaigns and CLI ask of a task (excavsim.loop.scenario) --------

def spec_episode(spec, resolved, *, progress: Callable[[str], None] | None = None,
                 observer: EpisodeObserver | None = None) -> Episode:
    """The :class:`~excavsim.loop.episode.Episode` of a trench specification (not yet reset): its
    goal, stopping rules and configurations (``resolved``, a
    :class:`~excavsim.tasks.trench.spec.TrenchResolved`), and its observers, with the online learner of
    ``spec.predictor`` first when it is not the nominal wedge (learned online, from scratch, from this
    episode's digs, §5.2)."""
    o = spec.options
    if o.predictor != "wedge":
        from excavsim.handoff.episode import ObserverGroup
        from excavsim.rig.online import OnlineLearning

        observer = ObserverGroup(OnlineLearning(o.predictor, progress=progress), observer)
    r = resolved
    task = TrenchTask(goal=r.goal, done_fraction=o.done_fraction, tolerance_m=o.tolerance_m,
                      planner_cfg=r.planner, executor_cfg=r.executor, sensing_cfg=r.sensing, robot_cfg=r.robot,
                      scene_cfg=r.scene, machine=r.machine)
    return Episode(task, dig_budget=spec.dig_budget, progress=progress, observer=observer)


def spec_digs(spec) -> PlannedDigs:
    """The dig source of a trench specification: the planner, with the memory of failed digs when ``spec.memory``."""
    return PlannedDigs(DigExperience() if spec.options.memory else None)


def episode_timer():
    """The observer of ``excavsim trench --timing``: Table 7 of Singh 1995 (§7.3), :class:`~excavsim.tasks.trench.timing.Table7Timer`."""
    from excavsim.tasks.trench.timing import Table7Timer

    return Table7Timer()


def dig_rows(res: EpisodeResult) -> list[dict[str, Any]]:
    """One JSON-ready row per dig of a trenching episode: its action (NaN for a fallback dig), volumes [l],
    outcome and failure, and the predicted and measured peak wrist-pitch torques [N m]."""
    rows = []
    for d in res.digs:
        k, a, d1, d2 = d.action if d.action is not None else (math.nan,) * 4
        rows.append({"dig": d.index, "kind": d.kind, "k_m": k, "alpha_deg": math.degrees(a), "d1_m": d1, "d2_m": d2,
                     "planned_l": 1000 * d.predicted_m3, "dug_l": 1000 * d.bucket_m3, "outcome": d.outcome,
                     "failure": d.failure or "", "stall_joint": d.stall_joint or "",
                     "wrist_predicted_nm": float(d.predicted_peak_nm[2]),
                     "wrist_measured_nm": float(d.peak_torque_nm[3])})
    return rows


def summary(res: EpisodeResult) -> dict[str, Any]:
    """A trenching episode's metrics as a flat dict of JSON numbers and strings (its campaign row; see
    :func:`~excavsim.loop.scenario.episode_summary`)."""
    digs = res.digs
    n = len(digs)
    peaks = [d.peak_torque_nm for d in digs]
    joints = ("waist", "shoulder", "elbow", "wrist_pitch", "wrist_yaw", "wrist_roll")
    out: dict[str, Any] = {
        "task": res.task or "trench", "end": res.end, "reason": res.reason, "digs": n, "fallback_digs": sum(d.kind != "planned" for d in digs),
        "stalls": sum(d.stall_joint is not None for d in digs),
        "failed_digs": sum(d.failed for d in digs), "failed_fraction": sum(d.failed for d in digs) / n if n else 0.0,
        "no_contact_digs": sum(d.outcome == "no contact" for d in digs),
        "diverged_digs": sum(d.outcome == "diverged" for d in digs),
        "little_soil_digs": sum(d.outcome != "no contact" and d.stall_joint is None and not d.bucket_m3 >= 0.001
                                for d in digs),
        "goal_l": 1000 * res.goal_m3, "removed_l": 1000 * res.removed_m3, "removed_fraction": res.removed_fraction,
        "dug_l_per_dig": 1000 * sum(d.bucket_m3 for d in digs) / n if n else 0.0,
        "planned_l_per_dig": 1000 * sum(d.predicted_m3 for d in digs) / n if n else 0.0,
        "efficiency": sum(d.efficiency for d in digs) / n if n else 0.0,
        "overdig_max_cm": 100 * res.overdig_max_m, "overdig_rms_cm": 100 * res.overdig_rms_m,
        "underdig_max_cm": 100 * res.underdig_max_m, "underdig_rms_cm": 100 * res.underdig_rms_m,
        "planning_s": sum(d.planning_s for d in digs), "sim_s": res.sim_time_s, "wall_s": res.wall_time_s,
        "cumulative_torque_knm_s": sum(d.cumulative_torque_nm_s for d in digs) / 1000,
        "volume_change_m3": res.volume_change_m3,
    }
    for j, name in enumerate(joints[1:4], start=1):
        out[f"peak_{name}_nm"] = max((float(p[j]) for p in peaks), default=0.0)
    out["dug_l"] = [round(1000 * d.bucket_m3, 3) for d in digs]
    return out
