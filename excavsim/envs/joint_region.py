"""The joint-level region goal: an excavator empties a box of its pit (``excavsim/ExcavatorJoint-v0``).

:class:`JointRegion` is one of :class:`~excavsim.envs.joint_core.JointCore`'s goals, the platform's own (no
task's): a box in the pit in front of the machine at swing 0, from the ground down to a depth
(:data:`REGIONS`, one per machine of the registry that has one), measured on the true terrain; the agent
observes the soil left in it and in the bucket (privileged truth; a scanned estimate is the loop's job).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from excavsim.envs.core import EnvError, Field
from excavsim.loop.catalog import DEFAULT_TASK
from excavsim.robot.excavators import EXCAVATOR_25T, TB035
from excavsim.robot.extract import arm_from_model

EXCAVATOR_WEIGHTS = {"removed_per_l": 1.0, "overdig_per_l": 2.0, "relief_per_s": 0.1, "time_per_s": 0.0}
"""The region goal's reward weights (each term in :class:`JointRegion`'s docstring): per litre removed from
the region (above the goal depth inside its footprint), per litre dug below the goal depth, per second of
each cylinder at its relief force, per second of the episode."""
REGIONS = {TB035.name: {"near_x_m": 2.6, "far_x_m": 3.8, "half_width_m": 0.35, "depth_m": 0.3},
           EXCAVATOR_25T.name: {"near_x_m": 5.0, "far_x_m": 7.5, "half_width_m": 0.7, "depth_m": 0.8}}
"""The goal region of each machine that has one (by its name in the machine registry,
:mod:`excavsim.robot.excavators`), in its arm plane at swing 0: radial extent [m], half width [m], depth
below the ground [m]."""
DEFAULT_MACHINE = TB035.name
"""The machine of an episode whose spec and keywords name none: DiMaio 1998's TB035."""
DEFAULT_SOIL = "dry_sand"
"""The soil of an episode whose spec and keywords name none (a preset of configs/soils.yaml)."""
RELIEF = 0.97  # a cylinder at this fraction of its relief force counts as at relief
DONE_FRACTION = 0.05  # the episode terminates when this fraction of the region's soil is left
TIP_BOUND_M = 20.0  # the tip observation's bound [m, rad] (readings are clipped to it)
START_MOVE_S = 2.0  # the simulated move from the home keyframe to the start [s]


class JointRegion:
    """A box of the pit emptied at the joint level (the goal ``region`` of
    :class:`~excavsim.envs.joint_core.JointCore`), on a machine with cylinders.

    Its observation entries (float32, after the machine's): ``tip`` (the bucket tip's radius from the swing
    axis, height [m] and blade angle [rad] from the machine's kinematic model), ``bucket_soil`` (soil in the
    bucket [m^3]: privileged truth, what a bucket-weighing estimate would give), ``region_soil`` (soil left in
    the goal region [m^3]: privileged truth) and ``time_left`` [s].

    Reward per step, on the true terrain, the sum of (``info["reward_terms"]``):

    * ``removed``: ``removed_per_l`` x litres newly removed from the region (negative when soil falls back);
    * ``overdig``: -``overdig_per_l`` x litres newly dug below the goal depth inside the footprint;
    * ``relief``: -``relief_per_s`` x seconds x cylinders at 97 % of their relief force (stalling);
    * ``time``: -``time_per_s`` x seconds.

    The episode starts with the bucket above the region's far half at a height, radius and swing drawn from
    the episode's seed (moved there from the ``home`` keyframe by the drive in 2 s of simulated time before
    the first observation; the clock then starts at 0); it terminates when 5 % of the region's soil is left
    or the world diverges, and is truncated after ``max_time_s`` (control steps times the control period).
    Without a machine or soil in the spec the goal takes the TB035 in dry sand (:attr:`SPEC_DEFAULTS`). The
    world is configured by an episode specification of the default task (:attr:`TASK`: its machine, soil and
    configuration files).

    Args:
        core: the core it is the goal of (its machine must have a region in :data:`REGIONS`).

    Raises:
        EnvError: the machine has no region.
    """

    NAME = "region"
    TASK = DEFAULT_TASK
    WEIGHTS = EXCAVATOR_WEIGHTS
    MAX_TIME_S = 20.0
    SPEC_DEFAULTS = {"machine": DEFAULT_MACHINE, "soil": DEFAULT_SOIL}
    OPTIONS = ()
    READS_TORQUES = False  # the relief term reads the cylinders' forces
    BATCH = None  # no compiled path: the batched environment steps it copy by copy

    def __init__(self, core):
        name = core.machine.name
        if name not in REGIONS or core.machine.force_reading != "cylinders":
            raise EnvError(f"the region goal has a region for machines {', '.join(REGIONS)}; given machine {name!r}")
        self.core = core
        self.region = REGIONS[name]
        g = self.region
        self.lookat = ((g["near_x_m"] + g["far_x_m"]) / 2, 0.0, 0.0)
        """Where a camera looks: the region's middle on the ground [m]."""
        self._relief = np.maximum(-core.force_low, core.force_high)

    def fields(self) -> dict[str, Field]:
        """The goal's observation entries."""
        return {
            "tip": Field((3,), "float32", -TIP_BOUND_M, TIP_BOUND_M,
                         doc="bucket tip radius, height [m], blade angle [rad]"),
            "bucket_soil": Field((1,), "float32", 0.0, 10.0, doc="soil in the bucket [m^3] (truth)"),
            "region_soil": Field((1,), "float32", 0.0, 100.0, doc="soil left in the goal region [m^3] (truth)"),
            "time_left": Field((1,), "float32", 0.0, self.core.max_time_s, doc="simulated time left [s]"),
        }

    # -- reset ----------------------------------------------------------------------------------
    def start(self, seed: int, options: Mapping[str, Any] | None) -> tuple[float, float, float]:
        """The start drawn from ``seed``: the tip's radius and height [m] and the swing [rad].

        Raises:
            EnvError: options given (the region takes none).
        """
        if options:
            raise EnvError(f"the region goal takes no reset options; given {dict(options)!r}")
        rng = np.random.default_rng(seed)
        g = self.region
        x = rng.uniform((g["near_x_m"] + g["far_x_m"]) / 2, g["far_x_m"])
        height = rng.uniform(0.1, 0.3)
        swing = rng.uniform(-0.05, 0.05)
        return x, height, swing

    def reset(self, sim, seed: int, start: tuple[float, float, float]) -> dict[str, Any]:
        """The region on the fresh world ``sim`` and the machine moved to ``start``; the reset's info.

        Raises:
            EnvError: the start is out of the machine's reach.
        """
        self.arm = arm_from_model(sim.model, joints=self.core.machine.chain_joints)
        g = sim.soil.grid
        xs, ys = np.meshgrid(g.x0 + np.arange(g.shape[1]) * g.cell, g.y0 + np.arange(g.shape[0]) * g.cell)
        r = self.region
        self._mask = (xs >= r["near_x_m"]) & (xs <= r["far_x_m"]) & (np.abs(ys) <= r["half_width_m"])
        self._z_goal = -r["depth_m"] - g.z0  # the goal depth in the grid's heights
        self._cell_area = g.cell * g.cell
        x, height, swing = start
        q, ok = self.arm.inverse(np.array([x, height, 0.6]))
        if not ok:
            raise EnvError(f"the start pose x {x:.2f} m, height {height:.2f} m is out of the "
                           f"{self.core.machine.name}'s reach")
        target = np.r_[swing, q]
        for _ in range(int(round(START_MOVE_S / sim.control_dt))):
            sim.step(target)
        sim.data.time = 0.0
        self._t0_steps = sim.steps
        self._above, self._below = self._measure()
        self._initial = self._above
        return {"seed": seed, "start": target.copy(), "region_soil_m3": self._initial}

    def _measure(self) -> tuple[float, float]:
        """Soil above the goal depth in the footprint, and the volume dug below it [m^3]."""
        h = self.core.sim.soil.grid.heights[self._mask]
        above = float(np.maximum(h - self._z_goal, 0.0).sum()) * self._cell_area
        below = float(np.maximum(self._z_goal - h, 0.0).sum()) * self._cell_area
        return above, below

    def started(self) -> None:
        """Nothing to set once the first observation is read."""

    def elapsed(self) -> float:
        """Simulated time since the start [s]: control steps times the control period."""
        sim = self.core.sim
        return (sim.steps - self._t0_steps) * sim.control_dt

    # -- step -----------------------------------------------------------------------------------
    def account(self, reading, measured: tuple[float, float] | None = None) -> dict[str, Any]:
        """The reward's terms, the ends and the info of a step the world has taken."""
        core = self.core
        sim, w = core.sim, core.weights
        above, below = self._measure() if measured is None else measured
        forces = sim.cylinder_forces()
        dt = sim.control_dt
        terms = {"removed": w["removed_per_l"] * 1000.0 * (self._above - above),
                 "overdig": -w["overdig_per_l"] * 1000.0 * max(below - self._below, 0.0),
                 "relief": -w["relief_per_s"] * dt * float(np.sum(np.abs(forces[1:]) >= RELIEF * self._relief[1:])),
                 "time": -w["time_per_s"] * dt}
        self._above, self._below = above, below
        terminated = above <= DONE_FRACTION * self._initial
        truncated = not terminated and self.elapsed() >= core.max_time_s - 1e-9
        info = {"reward_terms": terms, "region_soil_m3": above, "removed_m3": self._initial - above,
                "bucket_m3": float(sim.soil.volumes().bucket), "diverged": ""}
        return {"terms": terms, "terminated": terminated, "truncated": truncated, "info": info}

    def finish(self, terms: dict[str, float]) -> None:
        """No term waits for the observation."""

    # -- observation ----------------------------------------------------------------------------
    def observe(self, reading) -> dict[str, np.ndarray]:
        """The goal's entries of the observation of ``reading``."""
        sim = self.core.sim
        return {
            "tip": np.clip(self.arm.forward(reading.q[self.core.driven[1:]]), -TIP_BOUND_M, TIP_BOUND_M).astype(np.float32),
            "bucket_soil": np.array([min(max(sim.soil.volumes().bucket, 0.0), 10.0)], dtype=np.float32),
            "region_soil": np.array([min(self._above, 100.0)], dtype=np.float32),
            "time_left": np.array([max(self.core.max_time_s - self.elapsed(), 0.0)], dtype=np.float32),
        }
