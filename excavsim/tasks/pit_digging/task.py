"""Digging a rectangular pit with the T3, lane by lane: the episode's task part, its result and rows.

:class:`PitTask` is what the task supplies to the platform's :class:`~excavsim.loop.episode.Episode`
(its :class:`~excavsim.loop.episode.Task` hooks). It builds the T3's world and digging rig
(:func:`~excavsim.rig.core.make_rig`), and one rig per lane: the same arm, scanner and executor with
the lane's goal and planner (:func:`~excavsim.rig.core.make_planner`, the reachability table shared).
Each cycle it parks the arm, scans the box (:func:`~excavsim.rig.core.scan`), tests the map against
the pit, asks its dig source for a dig (:class:`~excavsim.tasks.pit_digging.digs.LaneDigs`: the lane with the
most soil), executes it in that lane's plane and lets the soil settle
(:func:`~excavsim.rig.core.execute_dig`). It is done when the map shows the pit within tolerance:
``done_fraction`` of its soil removed, no sample more than ``tolerance_m`` above its goal. Its result is
an :class:`~excavsim.handoff.episode.EpisodeResult`: the digs' metrics and the pit against its goal on
the true terrain (:func:`~excavsim.rig.measures.episode_result`, privileged).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
from scipy.ndimage import binary_erosion

from excavsim.config import (ExecutorConfig, PlannerConfig, SceneConfig, SensingConfig, TrenchGoal, get_soil,
                             load_config, load_executor_config, load_planner_config, load_scene_config,
                             load_sensing_config)
from excavsim.config.semantic import check_goal, soil_box
from excavsim.errors import GoalError
from excavsim.handoff.episode import DigMetrics, EpisodeResult
from excavsim.handoff.goal import goal_met
from excavsim.handoff.observation import Diverged, OutOfTime
from excavsim.loop.episode import Episode, world_failed
from excavsim.loop.scenario import override
from excavsim.rig.core import (bucket_witness, execute_dig, go_home, make_planner, make_rig, park, planner_limits,
                               scan, world_stop)
from excavsim.rig.measures import episode_result
from excavsim.tasks.pit_digging.digs import LaneDigs
from excavsim.tasks.pit_digging.goal import PitGoal, bucket_width_m, pit_lanes, pit_surface
from excavsim.world.machines import make_world

NAME = "pit_digging"
BASES = {"scene": (load_scene_config, SceneConfig), "planner": (load_planner_config, PlannerConfig),
         "executor": (load_executor_config, ExecutorConfig), "sensing": (load_sensing_config, SensingConfig)}
"""The configuration files a specification may override, with their models."""
SPOIL_CLEARANCE_M = 0.3  # the spoil's pile (about 0.4 m in radius for the small pit's 40 l at 30 degrees) and the pit


@dataclasses.dataclass(frozen=True)
class PitResolved:
    """What a pit specification stands for: the pit, its lanes and the configurations, overrides applied."""

    pit: PitGoal
    lanes: tuple[TrenchGoal, ...]
    scene: SceneConfig
    planner: PlannerConfig
    executor: ExecutorConfig
    sensing: SensingConfig


def resolve(spec) -> PitResolved:
    """The pit of ``spec`` (inline or a YAML file), its lanes checked against the box, and the configurations.

    Raises:
        ConfigError: naming the file or field and what is allowed.
    """
    o = spec.options
    pit = o.pit if isinstance(o.pit, PitGoal) else load_config(o.pit, PitGoal)
    cfg = {k: override(load(), getattr(o, k), model, f"{spec.name}: {k}") for k, (load, model) in BASES.items()}
    if spec.soil:
        cfg["scene"] = cfg["scene"].model_copy(update={"soil": spec.soil})
    box = soil_box()
    if not (box.x_min <= pit.near_x_m and pit.far_x_m <= box.x_max and box.y_min <= pit.y_min_m and pit.y_max_m <= box.y_max):
        raise GoalError(f"{spec.name}: pit: the opening x {pit.near_x_m:g}..{pit.far_x_m:g} m, y {pit.y_min_m:g}.."
                        f"{pit.y_max_m:g} m is not inside the soil box (allowed: x in [{box.x_min:g}, {box.x_max:g}] m, "
                        f"y in [{box.y_min:g}, {box.y_max:g}] m)")
    reach, waist = cfg["executor"].dump_pose[0], math.radians(cfg["executor"].spoil_waist_deg)
    spoil = np.array([reach * math.cos(waist), reach * math.sin(waist)])  # where the script dumps [m]
    gap = np.hypot(*np.clip(spoil, [pit.near_x_m, pit.y_min_m], [pit.far_x_m, pit.y_max_m]) - spoil)
    if gap < SPOIL_CLEARANCE_M:
        raise GoalError(f"{spec.name}: pit: the spoil the dig script dumps at ({spoil[0]:.2f}, {spoil[1]:.2f}) m "
                        f"(configs/executor.yaml: spoil_waist_deg, dump_pose) lies {gap:.2f} m from the opening "
                        f"(allowed: at least {SPOIL_CLEARANCE_M:g} m; move the pit or the spoil)")
    lanes = tuple(pit_lanes(pit, bucket_width_m()))
    for lane in lanes:
        check_goal(lane, cfg["scene"], source=f"{spec.name}: pit, {lane.name}")
    return PitResolved(pit, lanes, **cfg)


class PitTask:
    """A pit dug lane by lane by the T3 (see the module docstring).

    Args:
        resolved: the pit, its lanes and the configurations.
        done_fraction, tolerance_m: the done test on the map.
    """

    final_scan = True

    def __init__(self, resolved: PitResolved, *, done_fraction: float, tolerance_m: float):
        self.resolved, self.done_fraction, self.tolerance_m = resolved, done_fraction, tolerance_m
        self.wall_limit_s = math.inf

    def reset(self, seed, world=None, digs=None):
        r = self.resolved
        self.sim = sim = world if world is not None else make_world("t3", None, r.scene, seed=seed)
        base = make_rig(sim, seed=seed, goal=r.lanes[0], planner_cfg=r.planner, executor_cfg=r.executor,
                        sensing_cfg=r.sensing)
        limits, soil = planner_limits(sim), get_soil(sim.scene.soil)
        self.lanes = [dataclasses.replace(base, goal=g, planner=make_planner(
            base.arm, limits, base.width, base.capacity, g, r.planner, soil, table=base.planner.table)) for g in r.lanes]
        self.rig = self.lanes[len(self.lanes) // 2]  # the lane of the last dig (the middle one before the first)
        grid = sim.soil.grid
        xs, ys = grid.xy(*np.indices(grid.shape))
        self.z_goal = pit_surface(r.pit, xs, ys)
        self.mask = self.z_goal < r.pit.surface_z_m  # the pit's cells: below the surface in the goal
        # where the done test reads the map: the pit's cells a map cell or more inside its edge (the map's
        # bilinear heights nearer the edge mix in the soil around the pit)
        inside = binary_erosion(self.mask, iterations=math.ceil(r.sensing.map.cell_size_m / grid.cell))
        self._at = (xs[inside], ys[inside], self.z_goal[inside])
        self.source = digs or LaneDigs()
        self.metrics: list[DigMetrics] = []
        self.initial_heights, self._v0 = sim.soil.grid.heights.copy(), sim.soil.initial_volume
        self._witness = bucket_witness(sim)
        self.wall_limit_s = base.executor_cfg.episode_wall_limit_s
        self.emap = None
        return sim, self.rig, self.mask, self.z_goal, self.lanes, r.pit

    def scan(self):
        self.scanned = scan(self.sim, self.rig)
        return self.scanned

    def park(self) -> None:
        park(self.sim, self.rig)

    def assess(self, index, scanned, say):
        x, y, z_goal = self._at
        self.emap = scanned
        done, frac = goal_met(scanned.height_at(x, y), z_goal, self.resolved.pit.surface_z_m,
                              done_fraction=self.done_fraction, tolerance_m=self.tolerance_m)
        say(f"dig {index}: map {100 * frac:.0f} % of the pit removed (map RMS {100 * self.scanned[1].rms_m:.1f} cm)")
        return scanned, (("done", f"pit done on the map: {100 * frac:.0f} % removed, every sample within "
                                  f"{100 * self.tolerance_m:.0f} cm") if done else None)

    def choose(self, emap):
        return self.source.choose(self.lanes, emap)

    def execute(self, index, choice):
        self.rig = lane = self.lanes[choice.dig.lane]  # the dig is in this lane's arm plane
        try:
            go_home(self.sim, lane)
        except (Diverged, OutOfTime) as exc:
            return None, world_failed(exc, f"going home for dig {index}")
        dug = execute_dig(self.sim, lane, index, choice.dig, self.emap, witness=self._witness)
        self.metrics.append(dug[1])
        return dug, None

    def after(self, index, choice, dug, say):
        rec, m = dug
        say(f"  {m.kind}: {rec.outcome}, {1000 * m.predicted_m3:.1f} l planned, {1000 * m.bucket_m3:.1f} l dug")
        stop = world_stop(rec, index)
        if stop is None and (lesson := self.source.learned(self.lanes, index, choice.dig, rec, self.emap)):
            say(lesson)
        return stop

    def budget_reason(self, budget: int) -> str:
        return f"{budget} digs spent before the pit was done"

    def result(self, end, reason, wall_s) -> EpisodeResult:
        res = episode_result(self.sim, self.metrics, end, reason, mask=self.mask, z_goal=self.z_goal,
                             h0=self.initial_heights, v0=self._v0, wall_s=wall_s)
        return dataclasses.replace(res, task=NAME)


def spec_episode(spec, resolved: PitResolved, *, progress=None, observer=None) -> Episode:
    """The episode of a pit specification (not yet reset)."""
    task = PitTask(resolved, done_fraction=spec.options.done_fraction, tolerance_m=spec.options.tolerance_m)
    return Episode(task, dig_budget=spec.dig_budget, progress=progress, observer=observer)


def summary(res: EpisodeResult) -> dict[str, Any]:
    """A pit episode's campaign row: its end, the digs, the soil [l] and the pit against its goal [cm]."""
    digs, n = res.digs, max(len(res.digs), 1)
    return {"task": NAME, "end": res.end, "reason": res.reason, "digs": len(digs),
            "lanes_dug": len({d.kind for d in digs}), "stalls": sum(d.stall_joint is not None for d in digs),
            "failed_digs": sum(d.failed for d in digs), "dug_l_per_dig": 1000 * sum(d.bucket_m3 for d in digs) / n,
            **{f"{k}_l": 1000 * getattr(res, f"{k}_m3") for k in ("goal", "removed")},
            "removed_fraction": res.removed_fraction,
            **{f"{k}_cm": 100 * getattr(res, f"{k}_m") for k in ("overdig_max", "overdig_rms", "underdig_max",
                                                                  "underdig_rms")},
            "sim_s": res.sim_time_s, "wall_s": res.wall_time_s}


def dig_rows(res: EpisodeResult) -> list[dict[str, Any]]:
    """One row per dig: its lane, its action (k [m], alpha [rad], d1 [m], d2 [m]), the soil [l], how it went."""
    keys = ("k_m", "alpha_rad", "d1_m", "d2_m")
    return [{"dig": d.index, "lane": d.kind, **dict(zip(keys, d.action)), "planned_l": 1000 * d.predicted_m3,
             "dug_l": 1000 * d.bucket_m3, "outcome": d.outcome, "failure": d.failure or ""} for d in res.digs]
