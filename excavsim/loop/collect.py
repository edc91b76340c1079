"""Collecting force data by digging in the simulator (000_a3ca905d8c6d92bf.txt §5.2.4: ~4000 samples of 30 digs).

This module and :mod:`excavsim.loop.online` are where learning meets the world: they drive the
loop's pieces (``Simulation``, the rig of :func:`~excavsim.loop.cycle.make_rig`, scanning, the
planner, the dig executor). The rest of :mod:`excavsim.learning` is numpy, scipy and scikit-learn
on arrays.

:func:`collect_dataset` digs trenches in a fresh soil box ("bed") per ``digs_per_bed`` digs: park,
scan, plan on the map, then, instead of the planner's choice, execute a **random feasible
action** (seeded) among those sweeping at least ``min_volume_fraction`` of the bucket, so that
the data cover the action space and the terrain as the trench deepens; the rows of every dig are
taken from its execution record (:func:`~excavsim.learning.dataset.samples_from_record`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from excavsim import constants
from excavsim.errors import ExcavsimError
from excavsim.learning.dataset import ForceDataset, samples_from_record
from excavsim.learning.encoding import Terrain
from excavsim.robot.kinematics import PlanarArm


class TipTrace:
    """The tip pose after every control step, from the joint encoders (a ``Simulation`` step hook).

    Reads the planar joint angles (``qpos``) only: never the F/T noise stream, so that tracing does
    not change the episode.
    """

    def __init__(self, model, arm: PlanarArm):
        self.arm = arm
        self._qadr = np.array([model.jnt_qposadr[model.joint(j).id] for j in constants.PLANAR_JOINTS])
        self.clear()

    def __call__(self, sim) -> None:
        self._t.append(float(sim.data.time))
        self._q.append(sim.data.qpos[self._qadr].copy())

    def clear(self) -> None:
        self._t: list[float] = []
        self._q: list[np.ndarray] = []

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """Times (T,) [s] and tip poses (T, 3) (x, z, pitch) [m, m, rad]."""
        if not self._t:
            return np.zeros(0), np.zeros((0, 3))
        return np.asarray(self._t), self.arm.forward(np.asarray(self._q))


def collect_dataset(*, soil: str | None = None, digs: int = 30, seed: int = 0, goal: str = "straight",
                    digs_per_bed: int = 6, min_volume_fraction: float = 0.3, overrides: dict[str, Any] | None = None,
                    progress: Callable[[str], None] | None = None) -> ForceDataset:
    """Dig ``digs`` random feasible actions in simulated soil and tabulate their force samples.

    Args:
        soil: soil preset of configs/soils.yaml (default: the scene's).
        digs: number of digs.
        seed: seeds the soil beds (bed ``b`` has seed ``1000 seed + b``) and the choice of actions.
        goal: the trench the planner's feasible set is computed for (configs/trenches).
        digs_per_bed: digs before a fresh soil box (fewer when no feasible dig is left).
        min_volume_fraction: smallest swept volume of a chosen dig, as a fraction of capacity.
        overrides: ``robot``, ``scene``, ``planner``, ``executor``, ``sensing`` overrides as in an
            :class:`~excavsim.loop.scenario.EpisodeSpec`.
        progress: called with one line per dig.

    Returns:
        The data set; its metadata records the soil, seed, goal and number of digs.

    Raises:
        ExcavsimError: ``digs`` or ``digs_per_bed`` below 1, or no feasible dig in a fresh bed.
    """
    from excavsim.execution.dig import DigExecutor, DigPlan
    from excavsim.loop.cycle import HOME, _goto, _park, _scan, make_rig
    from excavsim.loop.scenario import EpisodeSpec, ResolvedSpec
    from excavsim.planning.trench import SurfaceProfile, goal_profile
    from excavsim.world.simulation import Simulation

    if digs < 1 or digs_per_bed < 1:
        raise ExcavsimError(f"collect_dataset needs digs >= 1 and digs_per_bed >= 1; given {digs}, {digs_per_bed}")
    say = progress or (lambda _s: None)
    spec = EpisodeSpec(name="learn", goal=goal, soil=soil, seed=seed, **(overrides or {}))
    cfg = ResolvedSpec(spec)
    rng = np.random.default_rng((seed, 8))
    parts: list[ForceDataset] = []
    bed = 0
    wall0 = time.perf_counter()
    while len(parts) < digs:
        sim = Simulation(cfg.robot, cfg.scene, seed=1000 * seed + bed)
        rig = make_rig(sim, seed=1000 * seed + bed, goal=cfg.goal, planner_cfg=cfg.planner, executor_cfg=cfg.executor,
                       sensing_cfg=cfg.sensing)
        executor = DigExecutor(sim, rig.arm, rig.executor_cfg)
        trace = TipTrace(sim.model, rig.arm)
        sim.step_hooks.append(trace)
        waist = math.radians(rig.goal.waist_deg)
        eps = math.radians(rig.planner_cfg.epsilon_deg)
        in_bed = 0
        while in_bed < digs_per_bed and len(parts) < digs:
            _park(sim, rig.executor_cfg)
            emap, _ = _scan(sim, rig.scanner, rig.sensing_cfg)
            plan = rig.planner.plan(emap)
            cells = np.argwhere(plan.feasible & (np.nan_to_num(plan.volume) >= min_volume_fraction * rig.capacity))
            if len(cells) == 0:
                if in_bed == 0:
                    raise ExcavsimError(f"no feasible dig sweeping {100 * min_volume_fraction:.0f} % of the bucket in "
                                        f"a fresh bed of {sim.scene.soil} for goal {goal!r}: lower min_volume_fraction")
                break
            c = tuple(cells[rng.integers(len(cells))])
            action = (float(plan.grid_k[c[0]]), float(plan.grid_alpha[c[1]]), float(plan.grid_d1[c[2]]),
                      float(plan.d2[c]))
            surface = SurfaceProfile.from_map(emap, rig.arm, waist, rig.width)
            poses, phases = rig.planner.trajectory(action, surface)
            clearance = float(np.min(poses[:, 1] - goal_profile(rig.goal, poses[:, 0])))
            _goto(sim, HOME, rig.executor_cfg)
            trace.clear()
            rec = executor.run(DigPlan(poses, phases, waist, float(plan.volume[c]), (-max(clearance, 0.0), math.inf)))
            sim.settle_soil()
            t, tip = trace.arrays()
            rows = samples_from_record(rec, trace_times=t, trace_poses=tip, terrain=Terrain.from_map(
                emap, rig.arm, waist, rig.width), phases=phases, epsilon=eps, width=rig.width, dig=len(parts))
            parts.append(rows)
            in_bed += 1
            k, a, d1, d2 = action
            peak = float(np.hypot(rows["fx"], rows["fz"]).max()) if len(rows) else 0.0
            say(f"dig {len(parts)}/{digs} (bed {bed + 1}): k {k:.2f} m, alpha {math.degrees(a):.0f} deg, "
                f"d1 {d1:.2f} m, d2 {d2:.2f} m -> {rec.outcome}, {len(rows)} samples, peak |F| {peak:.0f} N "
                f"[{time.perf_counter() - wall0:.0f} s]")
        sim.step_hooks.remove(trace)
        bed += 1
    return ForceDataset.concat(parts, meta={"soil": sim.scene.soil, "seed": str(seed), "goal": goal,
                                            "digs": str(len(parts)), "bucket_width_m": repr(rig.width),
                                            "source": "excavsim.loop.collect"})
