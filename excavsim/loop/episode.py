"""A trenching episode: the dig-scan-plan loop repeated until the trench is done (§7.2, Fig. 107).

Each cycle scans the box into an elevation map, plans one dig on the map, executes it with the dig
script and lets the soil settle. The episode ends when the trench meets its tolerance on the map
(at least ``done_fraction`` of the goal volume removed and no cell more than ``tolerance_m`` above
the goal profile), when the planner finds no dig of minimum utility, or when the dig budget is
spent. Metrics per dig and per episode follow the issue: soil per dig (predicted, in the bucket),
efficiency (bucket / capacity), over- and under-dig against the goal on the true terrain, stalls,
planning and simulated time, peak and cumulative torques, and why the episode ended.

When the planner's best dig is below the minimum utility, the boundary-following fallback of §7.2
(:mod:`excavsim.planning.fallback`) is tried before the episode gives up. An
:class:`EpisodeObserver` (the Rerun recorder, :mod:`excavsim.record`) sees every scan, plan,
control step and dig.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable

import numpy as np

from excavsim.config import ExecutorConfig, PlannerConfig, SensingConfig, TrenchGoal
from excavsim.execution.dig import DigExecutor, DigPlan
from excavsim.loop.cycle import HOME, _goto, _park, _scan, make_rig
from excavsim.planning import fallback
from excavsim.planning.trench import goal_profile
from excavsim.robot.kinematics import PlanarArm
from excavsim.world.simulation import Simulation


class EpisodeObserver:
    """Hooks into an episode; a recorder overrides the ones it needs (every default does nothing).

    Calls, in order: :meth:`started` once; per cycle :meth:`scanned`, then :meth:`planned` (with
    the planner's :class:`~excavsim.planning.trench.PlanResult` and, when the fallback ran, the
    chosen :class:`~excavsim.planning.fallback.FallbackDig` or None), :meth:`stepped` after every
    control step of the dig and the moves around it, :meth:`dug` after the soil settled;
    :meth:`finished` once at the end, also when the episode raised (then with None).
    """

    def started(self, sim: Simulation, rig, goal_mask: np.ndarray, goal_z: np.ndarray) -> None:
        """The world and the loop's pieces before the first scan."""

    def scanned(self, index: int, emap, accuracy) -> None:
        """The elevation map of cycle ``index`` (1-based) and its accuracy against the truth."""

    def planned(self, index: int, plan, fallback) -> None:
        """The planner's result of cycle ``index`` and the fallback dig (None when not needed or none)."""

    def stepped(self, sim: Simulation) -> None:
        """After each control step."""

    def dug(self, index: int, record, metrics: DigMetrics) -> None:
        """The execution record and metrics of dig ``index``, after settlement."""

    def finished(self, result: EpisodeResult | None) -> None:
        """The episode's result (None when it ended with an error)."""


class ObserverGroup(EpisodeObserver):
    """Several observers of one episode (a recorder and a learner, say), called in order."""

    def __init__(self, *observers: EpisodeObserver):
        self.observers = [o for o in observers if o is not None]

    def started(self, sim, rig, goal_mask, goal_z):
        for o in self.observers:
            o.started(sim, rig, goal_mask, goal_z)

    def scanned(self, index, emap, accuracy):
        for o in self.observers:
            o.scanned(index, emap, accuracy)

    def planned(self, index, plan, fallback):
        for o in self.observers:
            o.planned(index, plan, fallback)

    def stepped(self, sim):
        for o in self.observers:
            o.stepped(sim)

    def dug(self, index, record, metrics):
        for o in self.observers:
            o.dug(index, record, metrics)

    def finished(self, result):
        for o in self.observers:
            o.finished(result)


class MapWriter(EpisodeObserver):
    """Saves every scanned elevation map as ``DIR/map_<cycle>.npz`` (for ``excavsim plan --map``)."""

    def __init__(self, directory):
        import pathlib

        self.directory = pathlib.Path(directory)
        self.paths: list = []

    def started(self, sim, rig, goal_mask, goal_z):
        self.directory.mkdir(parents=True, exist_ok=True)

    def scanned(self, index, emap, accuracy):
        path = self.directory / f"map_{index:02d}.npz"
        emap.save(path)
        self.paths.append(path)


@dataclasses.dataclass
class DigMetrics:
    """One dig of an episode; ``kind`` is "planned" or "fallback: <boundary>" (§7.2).

    Peak and cumulative joint torques cover the soil-loaded part of the dig (touch-down to the end
    of the lift-out), sampled at the F/T rate.
    """

    index: int
    kind: str
    action: tuple[float, float, float, float] | None
    outcome: str
    predicted_m3: float
    bucket_m3: float
    efficiency: float
    stall_joint: str | None
    planning_s: float
    sim_s: float
    peak_torque_nm: np.ndarray
    cumulative_torque_nm_s: float


@dataclasses.dataclass
class EpisodeResult:
    """An episode's digs, its end, and the trench against the goal (true terrain)."""

    digs: list[DigMetrics]
    end: str  # "done", "no_dig" or "budget"
    reason: str
    goal_m3: float
    removed_m3: float
    overdig_max_m: float
    overdig_rms_m: float
    underdig_max_m: float
    underdig_rms_m: float
    sim_time_s: float
    wall_time_s: float
    volume_change_m3: float

    @property
    def removed_fraction(self) -> float:
        return self.removed_m3 / self.goal_m3 if self.goal_m3 > 0 else float("nan")


def trench_footprint(sim: Simulation, goal: TrenchGoal, width: float) -> tuple[np.ndarray, np.ndarray]:
    """Grid samples inside the trench's footprint (mask) and the goal profile height at each sample."""
    g = sim.soil.grid
    xs, ys = np.meshgrid(g.x0 + np.arange(g.shape[1]) * g.cell, g.y0 + np.arange(g.shape[0]) * g.cell)
    w = math.radians(goal.waist_deg)
    radial = xs * math.cos(w) + ys * math.sin(w)
    lateral = -xs * math.sin(w) + ys * math.cos(w)
    mask = (np.abs(lateral) <= width / 2) & (radial >= goal.near_x_m) & (radial <= goal.far_x_m)
    return mask, goal_profile(goal, radial)


def map_done(emap, goal: TrenchGoal, arm: PlanarArm, width: float, *, done_fraction: float, tolerance_m: float,
             initial_z: float) -> tuple[bool, float]:
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
                done_fraction: float = 0.95, tolerance_m: float = 0.03, planner_cfg: PlannerConfig | None = None,
                executor_cfg: ExecutorConfig | None = None, sensing_cfg: SensingConfig | None = None,
                progress: Callable[[str], None] | None = None,
                observer: EpisodeObserver | None = None) -> EpisodeResult:
    """Dig the trench: scan, plan (or fall back), dig, settle, until done, no dig, or ``dig_budget`` digs."""
    say = progress or (lambda _s: None)
    obs = observer or EpisodeObserver()
    wall0 = time.perf_counter()
    rig = make_rig(sim, seed=seed, goal=goal, planner_cfg=planner_cfg, executor_cfg=executor_cfg,
                   sensing_cfg=sensing_cfg)
    goal, executor_cfg, sensing_cfg, arm, scanner = rig.goal, rig.executor_cfg, rig.sensing_cfg, rig.arm, rig.scanner
    planner, width, capacity = rig.planner, rig.width, rig.capacity
    executor = DigExecutor(sim, arm, executor_cfg)
    mask, z_goal = trench_footprint(sim, goal, width)
    h0 = sim.soil.grid.heights.copy()
    v0 = sim.soil.initial_volume
    digs: list[DigMetrics] = []
    end, reason = "budget", f"dig budget of {dig_budget} spent"
    obs.started(sim, rig, mask, z_goal)
    sim.step_hooks.append(obs.stepped)
    result = None
    try:
        for i in range(dig_budget + 1):
            _park(sim, executor_cfg)
            emap, acc = _scan(sim, scanner, sensing_cfg)
            obs.scanned(i + 1, emap, acc)
            done, frac = map_done(emap, goal, arm, width, done_fraction=done_fraction, tolerance_m=tolerance_m,
                                  initial_z=goal.surface_z_m)
            say(f"dig {i + 1}: map {100 * frac:.0f} % of the goal removed (map RMS {100 * acc.rms_m:.1f} cm)")
            if done:
                end = "done"
                reason = (f"trench done on the map: {100 * frac:.0f} % removed, every cell within "
                          f"{100 * tolerance_m:.0f} cm")
                break
            if i == dig_budget:  # the last scan only checks whether the budget's digs finished the trench
                break
            plan = planner.plan(emap)
            dig = None
            if plan.action is None:
                dig, why = fallback.choose(planner, emap)
                obs.planned(i + 1, plan, dig)
                if dig is None:
                    end, reason = "no_dig", f"no dig of minimum utility ({plan.reason}), and no fallback: {why}"
                    break
                say(f"  planner: {plan.reason}; falling back to a {why}")
                poses, phases, volume, kind, action = dig.poses, dig.phases, dig.volume_m3, "fallback: " + dig.label, None
                planning_s = plan.seconds + dig.seconds
            else:
                obs.planned(i + 1, plan, None)
                poses, phases, volume, kind, action = plan.poses, plan.phases, plan.volume_m3, "planned", plan.action
                planning_s = plan.seconds
            _goto(sim, HOME, executor_cfg)
            t0 = sim.data.time
            clearance = float(np.min(poses[:, 1] - goal_profile(goal, poses[:, 0])))
            bounds = (-max(clearance, 0.0), 0.0 if dig is not None else math.inf)
            rec = executor.run(DigPlan(poses, phases, math.radians(goal.waist_deg), volume, bounds))
            sim.settle_soil()
            # torques while the soil loads the arm (touch-down to lift-out); the moves through
            # the air to the spoil and back are the servo's business, not the dig's
            lo, hi = rec.in_soil_window()
            tt = np.asarray(rec.times)
            sel = (tt >= lo) & (tt <= hi) if rec.torques else np.zeros(0, bool)
            torques = np.asarray(rec.torques)[sel] if sel.any() else np.zeros((1, 6))
            dt = 1.0 / executor.ft.rate_hz
            metrics = DigMetrics(
                index=i + 1, kind=kind, action=action, outcome=rec.outcome, predicted_m3=volume,
                bucket_m3=rec.bucket_volume_m3, efficiency=rec.bucket_volume_m3 / capacity,
                stall_joint=rec.stall["joint"] if rec.stall else None, planning_s=planning_s,
                sim_s=float(sim.data.time - t0), peak_torque_nm=np.abs(torques).max(axis=0),
                cumulative_torque_nm_s=float(np.abs(torques).sum() * dt))
            digs.append(metrics)
            obs.dug(i + 1, rec, metrics)
            say(f"  {kind} {rec.outcome}: {1000 * volume:.1f} l planned, {1000 * rec.bucket_volume_m3:.1f} l dug"
                + (f", stall at {metrics.stall_joint}" if metrics.stall_joint else ""))
        h = sim.soil.grid.heights
        removed = float(np.clip(h0 - h, 0, None)[mask].sum() * sim.soil.grid.cell_area)
        goal_m3 = float(np.clip(h0 - z_goal, 0, None)[mask].sum() * sim.soil.grid.cell_area)
        over = np.append(np.clip(z_goal - h, 0, None)[mask], 0.0)  # below the goal profile (0 if off the box)
        under = np.append(np.clip(h - z_goal, 0, None)[mask], 0.0)  # soil still above it
        result = EpisodeResult(
            digs=digs, end=end, reason=reason, goal_m3=goal_m3, removed_m3=removed, overdig_max_m=float(over.max()),
            overdig_rms_m=float(np.sqrt(np.mean(over[:-1] ** 2))) if over.size > 1 else 0.0,
            underdig_max_m=float(under.max()),
            underdig_rms_m=float(np.sqrt(np.mean(under[:-1] ** 2))) if under.size > 1 else 0.0,
            sim_time_s=float(sim.data.time),
            wall_time_s=time.perf_counter() - wall0, volume_change_m3=sim.soil.volumes().total - v0)
        return result
    finally:
        sim.step_hooks.remove(obs.stepped)
        obs.finished(result)


def format_episode(res: EpisodeResult) -> str:
    """The per-dig table and the episode summary."""
    lines = ["", f"{'dig':>3} {'k m':>5} {'alpha':>5} {'d1 m':>5} {'d2 m':>5} {'plan l':>7} {'dug l':>6} "
                 f"{'eff':>5} {'outcome':<15} {'stall':<18} {'wrist peak':>10}"]
    for d in res.digs:
        if d.action is None:  # a boundary-following fallback dig
            act = f"{d.kind[len('fallback: '):]:>23.23}"
        else:
            k, a, d1, d2 = d.action
            act = f"{k:5.2f} {math.degrees(a):5.0f} {d1:5.2f} {d2:5.2f}"
        lines.append(f"{d.index:>3} {act} {1000 * d.predicted_m3:7.1f} "
                     f"{1000 * d.bucket_m3:6.1f} {d.efficiency:5.2f} {d.outcome:<15} {d.stall_joint or '-':<18} "
                     f"{d.peak_torque_nm[3]:10.0f}")
    lines += ["", f"ended: {res.reason}",
              f"removed {1000 * res.removed_m3:.1f} l of {1000 * res.goal_m3:.1f} l ({100 * res.removed_fraction:.0f} %); "
              f"over-dig max {100 * res.overdig_max_m:.1f} cm (RMS {100 * res.overdig_rms_m:.1f}); under-dig max "
              f"{100 * res.underdig_max_m:.1f} cm (RMS {100 * res.underdig_rms_m:.1f})",
              f"{len(res.digs)} digs, {sum(d.stall_joint is not None for d in res.digs)} stalls; simulated "
              f"{res.sim_time_s:.0f} s in {res.wall_time_s:.1f} s wall; soil volume change {res.volume_change_m3:.1e} m^3"]
    return "\n".join(lines)
