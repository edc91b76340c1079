"""The excavator's joint-level environment core: a hydraulic excavator digging a goal region of its pit
at the control rate, free of any RL library (the core of ``excavsim/ExcavatorJoint-v0``, whose Gymnasium
face is :mod:`~excavsim.envs.excavator_env`).

The machine is one of the excavator models (``tb035``, DiMaio 1998's mini-excavator, by default; or
``excavator_25t``) in :class:`~excavsim.world.hydraulics.ExcavatorWorld`: the agent commands its four
valves, the servos' set-point rates of swing, boom, stick and bucket, each as a fraction of that function's
flow limit; the pumps' flow is then shared between the functions on one pump (Rowe 1997 §4.0,
:func:`~excavsim.robot.cylinders.share_pump_flow`), and each cylinder pushes within its relief force.
"""

from __future__ import annotations

import math
import types
from collections.abc import Mapping
from typing import Any

import numpy as np

from excavsim.envs.core import EnvError, Field, check_seed, check_vector, check_weights
from excavsim.handoff.observation import Diverged
from excavsim.robot.cylinders import share_pump_flow
from excavsim.robot.excavators import PUMPS
from excavsim.robot.extract import arm_from_model
from excavsim.world.hydraulics import EXCAVATOR_JOINTS, ExcavatorWorld

MACHINES = ("tb035", "excavator_25t")
EXCAVATOR_WEIGHTS = {"removed_per_l": 1.0, "overdig_per_l": 2.0, "relief_per_s": 0.1, "time_per_s": 0.0}
"""The reward weights (each term in :class:`ExcavatorJointCore`'s docstring): per litre removed from the goal
region (above the goal depth inside its footprint), per litre dug below the goal depth, per second of each
cylinder at its relief force, per second of the episode."""
# The goal region of each machine, in its arm plane at swing 0: radial extent [m], half width [m], depth [m]
GOALS = {"tb035": {"near_x_m": 2.6, "far_x_m": 3.8, "half_width_m": 0.35, "depth_m": 0.3},
         "excavator_25t": {"near_x_m": 5.0, "far_x_m": 7.5, "half_width_m": 0.7, "depth_m": 0.8}}
RELIEF = 0.97  # a cylinder at this fraction of its relief force counts as at relief
DONE_FRACTION = 0.05  # the episode terminates when this fraction of the region's soil is left
QDOT_MAX = 10.0  # the observation's joint speed bound [rad/s] (readings are clipped to it)


class ExcavatorJointCore:
    """An excavator digging its pit's goal region, one step per control period (50 Hz).

    Action: (4,) in [-1, 1], the valve commands of swing, boom, stick and bucket: each function's set-point
    rate as a fraction of its flow limit (positive: swing counter-clockwise, cylinders extending, i.e.
    boom up, stick and bucket in), before the pumps' sharing.

    Observation (float32 entries, :attr:`fields`): ``q`` and ``qdot`` (swing, boom, stick, bucket angles
    [rad] and speeds [rad/s], the encoders), ``cylinder_force`` (the swing torque [N m] and the three
    cylinder forces [N], the pressure transducers' reading, positive pushing), ``tip`` (the bucket tip's
    radius from the swing axis, height [m] and blade angle [rad] from the machine's kinematic model),
    ``bucket_soil`` (soil in the bucket [m^3]: privileged truth, what a bucket-weighing estimate would give)
    and ``region_soil`` (soil left in the goal region [m^3]: privileged truth; a scanned estimate is the
    loop's job), and ``time_left`` [s].

    The goal region (:data:`GOALS`): a box in the pit in front of the machine at swing 0, from the ground
    down to ``depth_m``. Reward per step, on the true terrain, the sum of (``info["reward_terms"]``):

    * ``removed``: ``removed_per_l`` x litres newly removed from the region (negative when soil falls back);
    * ``overdig``: -``overdig_per_l`` x litres newly dug below the goal depth inside the footprint;
    * ``relief``: -``relief_per_s`` x seconds x cylinders at 97 % of their relief force (stalling);
    * ``time``: -``time_per_s`` x seconds.

    The episode starts with the bucket above the region's far half at a height, radius and swing drawn
    from the episode's seed (moved there from the ``home`` keyframe by the drive in simulated time before
    the first observation); it terminates when 5 % of the region's soil is left or the world diverges, and
    is truncated after ``max_time_s``.

    Args:
        machine: ``tb035`` or ``excavator_25t``.
        soil: the soil preset (``configs/soils.yaml``).
        weights: reward weights over :data:`EXCAVATOR_WEIGHTS`.
        max_time_s: the episode's length in simulated time [s].
        seed: the default episode seed.
    """

    def __init__(self, machine: str = "tb035", *, soil: str = "dry_sand", weights: Mapping[str, float] | None = None,
                 max_time_s: float = 20.0, seed: int = 0):
        if machine not in MACHINES:
            raise EnvError(f"machine must be one of {', '.join(MACHINES)}; given {machine!r}")
        if isinstance(max_time_s, bool) or not isinstance(max_time_s, (int, float)) or not (
                math.isfinite(max_time_s) and max_time_s > 0):
            raise EnvError(f"max_time_s must be a finite number > 0; given {max_time_s!r}")
        self.machine, self.soil_name, self.max_time_s = machine, soil, float(max_time_s)
        self.weights = check_weights(weights, EXCAVATOR_WEIGHTS, "excavator")
        self.seed = check_seed(seed)
        # the settings the Gymnasium face's seeding reads (``spec.seed``, as the trench cores' episode spec)
        self.spec = types.SimpleNamespace(machine=machine, soil=soil, seed=self.seed)
        self.goal = GOALS[machine]
        self.world: ExcavatorWorld | None = None
        self._build(self.seed)
        w = self.world
        self.control_dt = w.control_dt
        self.action_low, self.action_high = -np.ones(4), np.ones(4)
        flim = np.abs(w.model.actuator_forcerange[w.drive.act])
        self._relief = np.maximum(flim[:, 0], flim[:, 1])
        self._force_lo, self._force_hi = -flim[:, 0], flim[:, 1]
        self._force_max = float(flim.max())  # the largest relief force (or swing torque) [N, N m]
        self.fields = {
            "q": Field((4,), "float32", -math.pi, math.pi,
                       doc="swing, boom, stick, bucket angles [rad] (within Table 4.2's limits on the TB035)"),
            "qdot": Field((4,), "float32", -QDOT_MAX, QDOT_MAX, doc="their speeds [rad/s] (clipped)"),
            "cylinder_force": Field((4,), "float32", -self._force_max, self._force_max,
                                    doc="swing torque [N m], boom, stick, bucket cylinder forces [N] (+ pushes; "
                                        "each within its relief limits)"),
            "tip": Field((3,), "float32", -20.0, 20.0, doc="bucket tip radius, height [m], blade angle [rad]"),
            "bucket_soil": Field((1,), "float32", 0.0, 10.0, doc="soil in the bucket [m^3] (truth)"),
            "region_soil": Field((1,), "float32", 0.0, 100.0, doc="soil left in the goal region [m^3] (truth)"),
            "time_left": Field((1,), "float32", 0.0, self.max_time_s, doc="simulated time left [s]"),
        }

    # -- the world ------------------------------------------------------------------------------
    def _build(self, seed: int) -> None:
        self.world = ExcavatorWorld(self.machine, self.soil_name, seed=seed)
        self.arm = arm_from_model(self.world.model, joints=EXCAVATOR_JOINTS)
        g = self.world.soil.grid
        xs, ys = np.meshgrid(g.x0 + np.arange(g.shape[1]) * g.cell, g.y0 + np.arange(g.shape[0]) * g.cell)
        goal = self.goal
        self._mask = (xs >= goal["near_x_m"]) & (xs <= goal["far_x_m"]) & (np.abs(ys) <= goal["half_width_m"])
        self._z_goal = -goal["depth_m"] - g.z0  # the goal depth in the grid's heights
        self._cell_area = g.cell * g.cell

    def _region(self) -> tuple[float, float]:
        """Soil above the goal depth in the footprint, and the volume dug below it [m^3]."""
        h = self.world.soil.grid.heights[self._mask]
        above = float(np.maximum(h - self._z_goal, 0.0).sum()) * self._cell_area
        below = float(np.maximum(self._z_goal - h, 0.0).sum()) * self._cell_area
        return above, below

    def reset(self, seed: int | None = None, options: Mapping[str, Any] | None = None):
        """A fresh world of episode seed ``seed`` (the core's when None); returns (observation, info).

        Raises:
            EnvError: a bad seed, or options given (this environment takes none).
        """
        if options:
            raise EnvError(f"ExcavatorJoint takes no reset options; given {dict(options)!r}")
        seed = self.seed if seed is None else check_seed(seed)
        self._build(seed)
        rng = np.random.default_rng(seed)
        goal = self.goal
        x = rng.uniform((goal["near_x_m"] + goal["far_x_m"]) / 2, goal["far_x_m"])
        height = rng.uniform(0.1, 0.3)
        swing = rng.uniform(-0.05, 0.05)
        q, ok = self.arm.inverse(np.array([x, height, 0.6]))
        if not ok:
            raise EnvError(f"the start pose x {x:.2f} m, height {height:.2f} m is out of the {self.machine}'s reach")
        target = np.r_[swing, q]
        for _ in range(int(round(2.0 / self.world.control_dt))):  # 2 s of simulated move from home
            self.world.step(target)
        self.world.data.time = 0.0
        self._t0_steps = self.world.steps
        self._above, self._below = self._region()
        self._initial = self._above
        self.done = False
        return self._observation(), {"seed": seed, "start": target.copy(), "region_soil_m3": self._initial}

    def step(self, action):
        """One control period; returns (observation, reward, terminated, truncated, info).

        Raises:
            EnvError: the action is not 4 numbers in [-1, 1], or the episode has ended (call reset).
        """
        if self.world is None or self.done:
            raise EnvError("the episode has ended (or not started): call reset()")
        a = check_vector(action, self.action_low, self.action_high, "action")
        a = np.clip(a, -1.0, 1.0)
        w = self.world
        v = np.where(a >= 0, a * w.drive.ctrl_hi, -a * w.drive.ctrl_lo)
        v = v * share_pump_flow(w.drive.flows(v), PUMPS, w.spec.pump_flow_m3_s)
        terminated = False
        try:
            w.step_rates(v)
        except Diverged as exc:
            terminated, diverged = True, str(exc)
        else:
            diverged = ""
        above, below = self._region()
        forces = w.cylinder_forces()
        dt = w.control_dt
        terms = {"removed": self.weights["removed_per_l"] * 1000.0 * (self._above - above),
                 "overdig": -self.weights["overdig_per_l"] * 1000.0 * max(below - self._below, 0.0),
                 "relief": -self.weights["relief_per_s"] * dt * float(np.sum(np.abs(forces[1:])
                                                                             >= RELIEF * self._relief[1:])),
                 "time": -self.weights["time_per_s"] * dt}
        self._above, self._below = above, below
        terminated = terminated or above <= DONE_FRACTION * self._initial
        truncated = not terminated and self._elapsed() >= self.max_time_s - 1e-9
        self.done = terminated or truncated
        info = {"reward_terms": terms, "region_soil_m3": above, "removed_m3": self._initial - above,
                "bucket_m3": float(w.soil.volumes().bucket), "diverged": diverged}
        return self._observation(), float(sum(terms.values())), terminated, truncated, info

    def _elapsed(self) -> float:
        return (self.world.steps - self._t0_steps) * self.world.control_dt

    def _observation(self) -> dict[str, np.ndarray]:
        w = self.world
        q = w.joint_angles()
        dof = w.model.jnt_dofadr[[w.model.joint(j).id for j in EXCAVATOR_JOINTS]]
        return {
            "q": np.clip(q, -math.pi, math.pi).astype(np.float32),
            "qdot": np.clip(w.data.qvel[dof], -QDOT_MAX, QDOT_MAX).astype(np.float32),
            "cylinder_force": np.clip(w.cylinder_forces(), self._force_lo, self._force_hi).astype(np.float32),
            "tip": np.clip(self.arm.forward(q[1:4]), -20.0, 20.0).astype(np.float32),
            "bucket_soil": np.array([min(max(w.soil.volumes().bucket, 0.0), 10.0)], dtype=np.float32),
            "region_soil": np.array([min(self._above, 100.0)], dtype=np.float32),
            "time_left": np.array([max(self.max_time_s - self._elapsed(), 0.0)], dtype=np.float32),
        }

    def close(self) -> None:
        """Free the world (closing twice is fine)."""
        self.world = None
