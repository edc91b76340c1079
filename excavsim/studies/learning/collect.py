"""Collecting force data by digging in the simulator (Singh 1995 §5.2.4: ~4000 samples of 30 digs).

This module and :mod:`excavsim.rig.online` are where learning meets the world: they run episodes (of the
default task, digging a trench goal) with an observer that turns every dig into force samples. The rest of :mod:`excavsim.learning` is numpy, scipy and scikit-learn on arrays.

:func:`collect_dataset` digs trenches in a fresh soil box ("bed") per ``digs_per_bed`` digs: one
episode per bed whose digs are **random feasible actions** (seeded: the task's ``random`` dig source)
among those sweeping at least
``min_volume_fraction`` of the bucket, instead of the planner's choice, so that the data cover the
action space and the terrain as the trench deepens; :class:`~excavsim.rig.samples.DigSamples`
takes the rows of every dig from its execution record.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from excavsim.errors import ConfigError, GoalError
from excavsim.learning.dataset import ForceDataset
from excavsim.rig.samples import DigSamples


class _Collector(DigSamples):
    """Keeps the samples of every dig of a bed and reports one line per dig."""

    def __init__(self, parts: list[ForceDataset], total: int, bed: int, wall0: float,
                 say: Callable[[str], None]):
        self.parts, self.total, self.bed, self.wall0, self.say = parts, total, bed, wall0, say

    def dug(self, index: int, record, metrics) -> None:
        rows = self.rows(record, len(self.parts))
        rows = ForceDataset.empty() if rows is None else rows
        self.parts.append(rows)
        k, a, d1, d2 = metrics.action
        peak = float(np.hypot(rows["fx"], rows["fz"]).max()) if len(rows) else 0.0
        self.say(f"dig {len(self.parts)}/{self.total} (bed {self.bed + 1}): k {k:.2f} m, alpha {math.degrees(a):.0f} "
                 f"deg, d1 {d1:.2f} m, d2 {d2:.2f} m -> {record.outcome}, {len(rows)} samples, peak |F| {peak:.0f} N "
                 f"[{time.perf_counter() - self.wall0:.0f} s]")


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
    from excavsim.loop.scenario import EpisodeSpec, resolve
    from excavsim.world.simulation import Simulation

    if digs < 1 or digs_per_bed < 1:
        raise ConfigError(f"collect_dataset needs digs >= 1 and digs_per_bed >= 1; given {digs}, {digs_per_bed}")
    say = progress or (lambda _s: None)
    # digging for data: never done early (done_fraction None), every dig of a bed's budget dug
    spec = EpisodeSpec(name="learn", goal=goal, soil=soil, seed=seed, done_fraction=None, **(overrides or {}))
    cfg = resolve(spec)
    source = spec.plugin.dig_source("random", np.random.default_rng((seed, 8)), min_volume_fraction)
    parts: list[ForceDataset] = []
    bed = 0
    wall0 = time.perf_counter()
    while len(parts) < digs:
        sim = Simulation(cfg.robot, cfg.scene, seed=1000 * seed + bed)
        collector = _Collector(parts, digs, bed, wall0, say)
        budget = min(digs_per_bed, digs - len(parts))
        episode = spec.plugin.episode(spec.model_copy(update={"dig_budget": budget}), cfg, observer=collector)
        episode.reset(1000 * seed + bed, sim=sim, digs=source)
        result = episode.run()
        if not result.digs:
            raise GoalError(f"no feasible dig sweeping {100 * min_volume_fraction:.0f} % of the bucket in "
                            f"a fresh bed of {sim.scene.soil} for goal {goal!r}: lower min_volume_fraction")
        bed += 1
    return ForceDataset.concat(parts, meta={"soil": sim.scene.soil, "seed": str(seed), "goal": goal,
                                            "digs": str(len(parts)), "bucket_width_m": repr(collector.rig.width),
                                            "source": "excavsim.studies.learning.collect"})
