"""The joint-level environment's core: the trenching world at the control rate, free of any RL library.

:class:`JointCore` is the core of ``excavsim/TrenchJoint-v0`` (its Gymnasium face is
:mod:`~excavsim.envs.joint_env`, its dm_env face :class:`~excavsim.envs.dm.DmTrenchJoint`): the
agent's set-point rates drive the waist, shoulder, elbow and wrist pitch servos directly (the wrist's
yaw and roll hold their home angles). The observation helpers it shares with the dig level
(:class:`~excavsim.envs.core.Field`, :class:`~excavsim.envs.core.TrueTrench`, the checks) stay in
:mod:`~excavsim.envs.core`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from excavsim.envs.core import EnvError, Field, TrueTrench, as_spec, check_seed, check_vector, check_weights
from excavsim.errors import ExcavsimError
from excavsim.handoff.goal import goal_profile
from excavsim.handoff.observation import Diverged, OutOfTime
from excavsim.loop.episode import map_done, trench_footprint
from excavsim.loop.rig import go_home, make_rig, scan
from excavsim.loop.scenario import ResolvedSpec
from excavsim.robot.fast import arm_params, forward_pose
from excavsim.robot.servo import setpoint_rates
from excavsim.sensing.ft import ForceSensor
from excavsim.world.simulation import Simulation


# -- the joint level ----------------------------------------------------------------------------
JOINT_WEIGHTS = {"cut_per_l": 1.0, "dump_per_l": 1.0, "overdig_per_l": 2.0, "saturation_per_s": 1.0}
"""The joint environment's default reward weights: per litre removed inside the goal, per litre
dumped to the spoil (outside the box), per litre dug below the goal profile, per second of each
driven joint at its torque limit."""
DRIVEN = (0, 1, 2, 3)  # waist, shoulder, elbow, wrist pitch: the joints the agent drives
SATURATION = 0.97  # a joint at this fraction of its relief limit counts as saturated (the executor's stall level)


class JointCore:
    """The trenching world at the control rate (the core of ``excavsim/TrenchJoint-v0``).

    The action is four set-point rates, for waist, shoulder, elbow and wrist pitch, each as a
    fraction in [-1, 1] of that servo's flow limit; the wrist's yaw and roll servos hold their home
    angles. One step is one control period of the simulation (``1 / control_rate_hz``, 10 ms).

    The observation is the joint encoders (angles and velocities of all six joints), the wrist F/T
    reading as the robot's sensor reports it (the soil's force and moment on the bucket about its
    tip, in the tip frame), the bucket tip's pose from the robot's own kinematic model, and a local
    height patch around the tip taken from the **scanned elevation map**, rescanned every
    ``scan_period_s`` of simulated time (the scanner's rays see the soil only, so the arm does not
    hide it; between scans the patch is the last map's), beside the goal's height at the same points.

    Reward, on the true terrain (privileged): soil removed above the goal profile inside the goal's
    footprint and soil dumped to the spoil (out of the box), per litre, less the over-dig below the
    goal profile per litre and the time driven joints spend at their relief limit (at least 97 %).
    The episode terminates when a scan shows the trench within tolerance (the loop's done rule) or
    the world diverges, and is truncated after ``max_time_s`` of simulated time.

    Args:
        spec: the world (goal, soil, seed, configuration overrides; see :func:`as_spec`); its dig
            budget is not used.
        weights: reward weights over :data:`JOINT_WEIGHTS`.
        max_time_s: the episode's length in simulated time [s].
        scan_period_s: simulated time between scans [s].
        patch_size, patch_spacing_m: the height patch, ``patch_size`` x ``patch_size`` points
            ``patch_spacing_m`` apart centred under the tip, in world axes.
    """

    def __init__(self, spec=None, *, weights: Mapping[str, float] | None = None, max_time_s: float = 60.0,
                 scan_period_s: float = 1.0, patch_size: int = 9, patch_spacing_m: float = 0.1,
                 robot_path=None, scene_path=None):
        self.spec = as_spec(spec)
        self.resolved = ResolvedSpec(self.spec, robot_path=robot_path, scene_path=scene_path)
        self.weights = check_weights(weights, JOINT_WEIGHTS, "joint")
        for name, v in (("max_time_s", max_time_s), ("scan_period_s", scan_period_s),
                        ("patch_spacing_m", patch_spacing_m)):
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise EnvError(f"{name} must be a finite number > 0; given {v!r}")
        if isinstance(patch_size, bool) or not isinstance(patch_size, int) or not 1 <= patch_size <= 101:
            raise EnvError(f"patch_size must be an integer from 1 to 101; given {patch_size!r}")
        self.max_time_s, self.scan_period_s = float(max_time_s), float(scan_period_s)
        self.patch_size, self.patch_spacing_m = patch_size, float(patch_spacing_m)
        off = (np.arange(patch_size) - (patch_size - 1) / 2) * self.patch_spacing_m
        self._off_x, self._off_y = np.meshgrid(off, off)
        self.control_dt = 1.0 / self.resolved.robot.control_rate_hz  # refined by the world at reset
        self.action_low, self.action_high = -np.ones(len(DRIVEN)), np.ones(len(DRIVEN))
        self.fields = {
            "q": Field((6,), "float64", -2 * math.pi, 2 * math.pi, doc="joint angles [rad]"),
            "qdot": Field((6,), "float64", -50.0, 50.0, doc="joint velocities [rad/s]"),
            "ft": Field((6,), "float64", -1e6, 1e6, doc="F/T: soil force [N] and moment [N m] on the bucket, "
                                                         "tip frame"),
            "tip": Field((4,), "float64", -10.0, 10.0, doc="bucket tip x, y, z [m] (world) and pitch [rad]"),
            "patch": Field((2, patch_size, patch_size), "float32", -5.0, 5.0,
                           doc="scanned terrain and goal heights around the tip, relative to the tip [m]"),
            "time_left": Field((), "float64", 0.0, self.max_time_s, doc="simulated time left [s]"),
        }
        self.sim: Simulation | None = None
        self.over = True
        self._closed = False

    def reset(self, seed: int) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """A fresh world with ``seed``, the arm at its ``home`` pose over the box, a first scan."""
        if self._closed:
            raise EnvError("the environment is closed")
        seed = check_seed(seed)
        r = self.resolved
        self.sim = sim = Simulation(r.robot, r.scene, seed=seed)
        self.rig = rig = make_rig(sim, seed=seed, goal=r.goal, planner_cfg=r.planner, executor_cfg=r.executor,
                                  sensing_cfg=r.sensing)
        self.control_dt = sim.control_dt
        self.ft = ForceSensor.from_config(sim.model, r.sensing.force_sensor)
        self._ft_out = np.zeros((4, 3))
        mask, z_goal = trench_footprint(sim, r.goal, rig.width)
        self.truth = TrueTrench(sim, mask, z_goal)
        go_home(sim, rig)
        self._hold = rig.home[4:].copy()
        self._rates = np.zeros(6)
        self._rate_limit = sim.rate_limit.copy()
        self._torque_limit = sim.torque_limit[list(DRIVEN)].copy()
        self._waist = math.radians(r.goal.waist_deg)
        self._arm_params = arm_params(rig.arm)
        self._scan()
        self.t0 = sim.time
        self._measured = self.truth.measure()
        self._spoil = self._spoil0 = float(sim.soil.spoil)
        self.over = False
        self.steps = 0
        obs = sim.observe()
        return self._observation(obs), {"time_s": 0.0, "map_removed_fraction": self._frac, "map_done": self._done}

    def _scan(self) -> None:
        r = self.resolved
        self.emap, _ = scan(self.sim, self.rig)
        self._scanned_at = self.sim.time
        self._done, self._frac = map_done(self.emap, r.goal, self.rig.arm, self.rig.width,
                                          done_fraction=self.spec.done_fraction, tolerance_m=self.spec.tolerance_m,
                                          initial_z=r.goal.surface_z_m)
        self._frac = float(self._frac)

    def step(self, action: Any) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        """One control step with set-point rates ``action`` (4,) in [-1, 1] of each servo's flow limit.

        Raises:
            EnvError: the action is outside [-1, 1], not finite or of the wrong shape, or no episode runs.
        """
        if self.over:
            raise EnvError("the episode has ended (or never started): call reset() first")
        a = check_vector(action, self.action_low, self.action_high, "the joint action (rates in [-1, 1])")
        sim = self.sim
        q = sim.joint_angles()
        rates = self._rates
        rates[:4] = np.clip(a, -1.0, 1.0) * self._rate_limit[:4]
        rates[4:] = setpoint_rates(self._hold, q[4:], gain_per_s=float(sim.robot.setpoint_gain_per_s),
                                   rate_limit=self._rate_limit[4:])
        try:
            obs = sim.step(rates)
        except (Diverged, OutOfTime) as exc:
            self.over = True
            return (self._observation(sim.observe()), 0.0, True, False,
                    {"time_s": sim.time - self.t0, "diverged": str(exc)})
        self.steps += 1
        w = self.weights
        removed, over = self.truth.measure()
        spoil = float(sim.soil.spoil)
        d_removed, d_over, d_spoil = removed - self._measured[0], over - self._measured[1], spoil - self._spoil
        self._measured, self._spoil = (removed, over), spoil
        saturated = int(np.count_nonzero(np.abs(obs.actuator_force[list(DRIVEN)]) >= SATURATION * self._torque_limit))
        reward = (1000 * (w["cut_per_l"] * d_removed + w["dump_per_l"] * d_spoil - w["overdig_per_l"] * d_over)
                  - w["saturation_per_s"] * saturated * sim.control_dt)
        elapsed = sim.time - self.t0
        if sim.time - self._scanned_at >= self.scan_period_s - 1e-9:
            self._scan()
        terminated = bool(self._done)
        truncated = not terminated and elapsed >= self.max_time_s - 1e-9
        self.over = terminated or truncated
        info = {"time_s": elapsed, "removed_l": 1000 * removed, "overdig_l": 1000 * over,
                "spoil_l": 1000 * (spoil - self._spoil0), "saturated_joints": saturated,
                "map_removed_fraction": self._frac, "map_done": bool(self._done)}
        return self._observation(obs), float(reward), terminated, truncated, info

    def _observation(self, obs) -> dict[str, np.ndarray]:
        sim, arm = self.sim, self.rig.arm
        q = np.array(obs.q, dtype=np.float64)
        x, z, pitch = forward_pose(self._arm_params, float(q[1]), float(q[2]), float(q[3]))
        phi = arm.waist_sign * float(q[0])  # PlanarArm.plane_to_world, on scalars
        c, s = math.cos(phi), math.sin(phi)
        y0 = arm.plane_offset_y
        tip = (arm.waist_axis_xy[0] + c * x - s * y0, arm.waist_axis_xy[1] + s * x + c * y0, z)
        try:
            ft = self.ft.reading_into(obs, self._ft_out)
            wrench = np.concatenate([ft[0], ft[1]])
        except ExcavsimError:  # a non-finite reading (a diverged world): report zeros
            wrench = np.zeros(6)
        px, py = tip[0] + self._off_x, tip[1] + self._off_y
        terrain = self.emap.height_at(px, py) - tip[2]
        r = self.resolved
        w = self._waist
        radial = px * math.cos(w) + py * math.sin(w)
        lateral = -px * math.sin(w) + py * math.cos(w)
        inside = (np.abs(lateral) <= self.rig.width / 2) & (radial >= r.goal.near_x_m) & (radial <= r.goal.far_x_m)
        goal = np.where(inside, goal_profile(r.goal, radial), r.goal.surface_z_m) - tip[2]
        return {"q": q, "qdot": np.array(obs.qdot, dtype=np.float64), "ft": wrench,
                "tip": np.array([tip[0], tip[1], tip[2], pitch]),
                "patch": np.stack([terrain, goal]).astype(np.float32),
                "time_left": np.array(max(self.max_time_s - (sim.time - self.t0), 0.0))}

    def close(self) -> None:
        """Free the world; a closed core cannot be reset (closing twice is fine)."""
        self.sim = None
        self.over = True
        self._closed = True
