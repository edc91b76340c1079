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

import mujoco
import numpy as np

from excavsim.envs.core import EnvError, Field, TrueTrench, as_spec, check_seed, check_vector, check_weights
from excavsim.errors import ExcavsimError
from excavsim.handoff.goal import goal_profile
from excavsim.handoff.observation import Diverged, OutOfTime
from excavsim.loop.measures import trench_footprint
from excavsim.loop.rig import go_home, make_rig, scan
from excavsim.loop.scenario import resolve
from excavsim.robot.fast import arm_params, forward_pose
from excavsim.robot.servo import setpoint_rates
from excavsim.sensing.ft import ForceSensor
from excavsim.tasks.trench.task import map_done
from excavsim.world.simulation import Simulation


# -- the joint level ----------------------------------------------------------------------------
JOINT_WEIGHTS = {"cut_per_l": 1.0, "load_per_l": 0.5, "dump_per_l": 1.0, "overdig_per_l": 2.0,
                 "saturation_per_s": 1.0, "stall_per_s": 2.0, "depth_per_m": 10.0, "time_per_s": 0.0}
"""The joint environment's default reward weights (each term in :class:`JointCore`'s docstring):
per litre removed above the goal inside its footprint, per litre gained in the bucket, per litre
dumped to the spoil, per litre dug below the goal profile, per second of each driven joint at its
relief limit, per second of each driven joint stalled there, the potential's slope per metre of the
tip below the scanned surface inside the footprint, per second of the episode."""
DRIVEN = (0, 1, 2, 3)  # waist, shoulder, elbow, wrist pitch: the joints the agent drives
SATURATION = 0.97  # a joint at this fraction of its relief limit counts as saturated (the executor's stall level)
STALL_SPEED = 0.02  # a saturated joint slower than this [rad/s] is stalled
DEPTH_CAP_M = 0.3  # the shaping potential's depth saturates here [m]
STARTS = ("home", "near_soil")
DIG_TASK = {"start": "near_soil", "max_time_s": 6.0, "scan_period_s": math.inf}
"""``excavsim/TrenchJointDig-v0``'s defaults: one dig from the bucket just above the soil, 600
steps, the map scanned once at reset (as the loop scans before each dig)."""
TRENCH_TASK = {"start": "near_soil", "max_time_s": 30.0, "scan_period_s": 1.0}
"""``excavsim/TrenchJoint-v0``'s defaults: the whole trench from just above the soil, 3,000 steps,
a scan every simulated second (the done rule reads the scan)."""


START_OPTIONS = ("start", "start_x_m", "start_height_m", "start_pitch_deg")
"""The reset options :meth:`JointCore.reset` takes."""


class JointCore:
    """The trenching world at the control rate (the core of the ``excavsim/TrenchJoint*`` environments).

    The action is four set-point rates, for waist, shoulder, elbow and wrist pitch, each as a
    fraction in [-1, 1] of that servo's flow limit; the wrist's yaw and roll servos hold their home
    angles. One step is one control period of the simulation (``1 / control_rate_hz``, 10 ms).

    The observation (all float32) is the joint encoders (angles and velocities of all six joints),
    the wrist F/T reading as the robot's sensor reports it (the soil's force and moment on the
    bucket about its tip, in the tip frame), the bucket tip's pose from the robot's own kinematic
    model, a local height patch around the tip taken from the **scanned elevation map**, rescanned
    every ``scan_period_s`` of simulated time (``math.inf``: only at reset, as the loop scans before
    each dig; the scanner's rays see the soil only, so the arm does not hide it; between scans the
    patch is the last map's) beside the goal's height at the same points, and the time left.

    The start (``start``, or the reset option of that name): ``"home"``, the arm at its ``home``
    keyframe high over the box; ``"near_soil"``, the tip placed by the robot's inverse kinematics
    in the goal's arm plane ``start_height_m`` above the goal's surface at radial distance
    ``start_x_m`` with pitch ``start_pitch_deg``, each drawn from the episode's seed when not given
    (x uniform over the far 60 % of the trench's opening, height uniform in [0.01, 0.06] m, pitch
    60 deg), the servos' states set there at rest (no simulated move).

    Reward per step, on the true terrain (privileged), the sum of these terms (``info["reward_terms"]``):

    * ``cut``: ``cut_per_l`` x litres newly removed above the goal profile inside its footprint;
    * ``load``: ``load_per_l`` x litres gained in the bucket (negative when soil leaves it);
    * ``dump``: ``dump_per_l`` x litres newly dumped to the spoil (out of the box);
    * ``overdig``: -``overdig_per_l`` x litres newly dug below the goal profile;
    * ``saturation``: -``saturation_per_s`` x seconds x driven joints at 97 % of their relief limit;
    * ``stall``: -``stall_per_s`` x seconds x those joints also slower than 0.02 rad/s;
    * ``depth``: potential-based shaping (Ng et al. 1999, with discount 1): the change of
      ``depth_per_m`` x the tip's depth below the scanned surface (capped at 0.3 m; 0 outside the
      goal's footprint), so that an episode's shaping sums to its last potential less its first and
      holding still earns nothing;
    * ``time``: -``time_per_s`` x seconds.

    The episode terminates when a scan shows the trench within tolerance (the loop's done rule) or
    the world diverges, and is truncated after ``max_time_s`` of simulated time.

    Args:
        spec: the world (goal, soil, seed, configuration overrides; see :func:`as_spec`); its dig
            budget is not used.
        weights: reward weights over :data:`JOINT_WEIGHTS`.
        max_time_s: the episode's length in simulated time [s] (the horizon: 100 steps a second).
        scan_period_s: simulated time between scans [s]; ``math.inf`` scans only at reset.
        patch_size, patch_spacing_m: the height patch, ``patch_size`` x ``patch_size`` points
            ``patch_spacing_m`` apart centred under the tip, in world axes.
        start: ``"home"`` or ``"near_soil"`` (above); the reset option overrides it.
    """

    def __init__(self, spec=None, *, weights: Mapping[str, float] | None = None, max_time_s: float = 60.0,
                 scan_period_s: float = 1.0, patch_size: int = 9, patch_spacing_m: float = 0.1,
                 start: str = "home", robot_path=None, scene_path=None):
        self.spec = as_spec(spec)
        self.resolved = resolve(self.spec, robot_path=robot_path, scene_path=scene_path)
        self.weights = check_weights(weights, JOINT_WEIGHTS, "joint")
        for name, v in (("max_time_s", max_time_s), ("scan_period_s", scan_period_s),
                        ("patch_spacing_m", patch_spacing_m)):
            if isinstance(v, bool) or not (isinstance(v, (int, float)) and v > 0 and not math.isnan(v)) or (
                    name != "scan_period_s" and not math.isfinite(v)):
                allowed = "a number > 0 (math.inf: only at reset)" if name == "scan_period_s" else "a finite number > 0"
                raise EnvError(f"{name} must be {allowed}; given {v!r}")
        if isinstance(patch_size, bool) or not isinstance(patch_size, int) or not 1 <= patch_size <= 101:
            raise EnvError(f"patch_size must be an integer from 1 to 101; given {patch_size!r}")
        self.start = _check_start(start)
        self.max_time_s, self.scan_period_s = float(max_time_s), float(scan_period_s)
        self.patch_size, self.patch_spacing_m = patch_size, float(patch_spacing_m)
        off = (np.arange(patch_size) - (patch_size - 1) / 2) * self.patch_spacing_m
        self._off_x, self._off_y = np.meshgrid(off, off)
        self.control_dt = 1.0 / self.resolved.robot.control_rate_hz  # refined by the world at reset
        self.action_low, self.action_high = -np.ones(len(DRIVEN)), np.ones(len(DRIVEN))
        self.fields = {
            "q": Field((6,), "float32", -2 * math.pi, 2 * math.pi, doc="joint angles [rad]"),
            "qdot": Field((6,), "float32", -50.0, 50.0, doc="joint velocities [rad/s]"),
            "ft": Field((6,), "float32", -1e6, 1e6, doc="F/T: soil force [N] and moment [N m] on the bucket, "
                                                         "tip frame"),
            "tip": Field((4,), "float32", -10.0, 10.0, doc="bucket tip x, y, z [m] (world) and pitch [rad]"),
            "patch": Field((2, patch_size, patch_size), "float32", -5.0, 5.0,
                           doc="scanned terrain and goal heights around the tip, relative to the tip [m]"),
            "time_left": Field((1,), "float32", 0.0, self.max_time_s, doc="simulated time left [s]"),
        }
        self.sim: Simulation | None = None
        self.over = True
        self._closed = False

    # -- reset ----------------------------------------------------------------------------------
    def reset(self, seed: int, options: Mapping[str, Any] | None = None
              ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """A fresh world with ``seed``, the arm at the start (see the class docstring), a first scan.

        Args:
            seed: the episode seed (the world's soil, sensor noise, scanner drift, the drawn start).
            options: any of :data:`START_OPTIONS`.

        Raises:
            EnvError: a bad seed or option, or a start pose the arm cannot reach.
        """
        if self._closed:
            raise EnvError("the environment is closed")
        seed = check_seed(seed)
        start = self._start_pose(seed, options)
        r = self.resolved
        self.sim = sim = Simulation(r.robot, r.scene, seed=seed)
        self.rig = rig = make_rig(sim, seed=seed, goal=r.goal, planner_cfg=r.planner, executor_cfg=r.executor,
                                  sensing_cfg=r.sensing)
        self.control_dt = sim.control_dt
        self.ft = ForceSensor.from_config(sim.model, r.sensing.force_sensor)
        self._ft_out = np.zeros((4, 3))
        mask, z_goal = trench_footprint(sim, r.goal, rig.width)
        self.truth = TrueTrench(sim, mask, z_goal)
        self._waist = math.radians(r.goal.waist_deg)
        if start is None:
            go_home(sim, rig)
        else:
            self._place(start)
        self._hold = rig.home[4:].copy()
        self._rates = np.zeros(6)
        self._rate_limit = sim.rate_limit.copy()
        self._torque_limit = sim.torque_limit[list(DRIVEN)].copy()
        self._arm_params = arm_params(rig.arm)
        self._scan()
        self.t0 = sim.time
        self._measured = self.truth.measure()
        self._spoil = self._spoil0 = float(sim.soil.spoil)
        self._load = float(sim.soil.load)
        self.over = False
        self.steps = 0
        self.reading = sim.observe()
        obs = self._observation(self.reading)
        self._potential = self._depth_potential()
        return obs, {"time_s": 0.0, "map_removed_fraction": self._frac, "map_done": self._done,
                     "start": "home" if start is None else "near_soil",
                     "start_pose": None if start is None else np.array(start)}

    def _start_pose(self, seed: int, options: Mapping[str, Any] | None) -> tuple[float, float, float] | None:
        """The start's tip pose (x, z, pitch) in the arm plane [m, m, rad], or None for home."""
        options = dict(options or {})
        unknown = sorted(set(options) - set(START_OPTIONS))
        if unknown:
            raise EnvError(f"unknown reset option(s) {unknown}; allowed: {', '.join(START_OPTIONS)}")
        start = _check_start(options.get("start", self.start))
        if start == "home":
            extra = sorted(set(options) - {"start"})
            if extra:
                raise EnvError(f"reset options {extra} need start='near_soil'; given start='home'")
            return None
        g = self.resolved.goal
        rng = np.random.default_rng((seed, 11))
        drawn = (rng.uniform(g.near_x_m + 0.4 * (g.far_x_m - g.near_x_m), g.far_x_m), rng.uniform(0.01, 0.06))
        values = []
        for name, default, low, high in (("start_x_m", drawn[0], g.near_x_m - 1.0, g.far_x_m + 1.0),
                                         ("start_height_m", drawn[1], -0.05, 1.0),
                                         ("start_pitch_deg", 60.0, 0.0, 150.0)):
            v = options.get(name, default)
            if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)) or not low <= v <= high:
                raise EnvError(f"reset option {name} must be a number from {low:g} to {high:g}; given {v!r}")
            values.append(float(v))
        return values[0], g.surface_z_m + values[1], math.radians(values[2])

    def _place(self, pose: tuple[float, float, float]) -> None:
        """Put the arm at rest with its tip at ``pose`` (x, z, pitch) in the goal's arm plane: the
        joints and the servos' integrator states set, velocities zero, wrist yaw and roll at home."""
        sim, rig = self.sim, self.rig
        q_arm, ok = rig.arm.inverse(np.asarray(pose, dtype=float))
        if not bool(np.all(ok)) or not np.all(np.isfinite(q_arm)):
            raise EnvError(f"the start pose (x {pose[0]:.3f} m, z {pose[1]:.3f} m, pitch "
                           f"{math.degrees(pose[2]):.1f} deg) is out of the arm's reach")
        q = rig.home.copy()
        q[0] = rig.arm.waist_sign * self._waist
        q[1:4] = q_arm
        _place_joints(sim, q)

    def _scan(self) -> None:
        r = self.resolved
        self.emap, _ = scan(self.sim, self.rig)
        self._scanned_at = self.sim.time
        self._done, self._frac = map_done(self.emap, r.goal, self.rig.arm, self.rig.width,
                                          done_fraction=self.spec.options.done_fraction, tolerance_m=self.spec.options.tolerance_m,
                                          initial_z=r.goal.surface_z_m)
        self._frac = float(self._frac)

    # -- step -----------------------------------------------------------------------------------
    def step(self, action: Any) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        """One control step with set-point rates ``action`` (4,) in [-1, 1] of each servo's flow limit.

        Raises:
            EnvError: the action is outside [-1, 1], not finite or of the wrong shape, or no episode runs.
        """
        rates = self.rates(action)
        try:
            obs = self.sim.step(rates)
        except (Diverged, OutOfTime) as exc:
            return self.diverged(exc)
        return self.after_step(obs)

    def rates(self, action: Any) -> np.ndarray:
        """The six servos' set-point rates [rad/s] for ``action`` (the first half of :meth:`step`)."""
        if self.over:
            raise EnvError("the episode has ended (or never started): call reset() first")
        return self.checked_rates(check_vector(action, self.action_low, self.action_high,
                                               "the joint action (rates in [-1, 1])"))

    def checked_rates(self, a: np.ndarray) -> np.ndarray:
        """:meth:`rates` of an action (4,) float64 already checked (the batched environment checks all at once)."""
        sim = self.sim
        rates = self._rates
        rates[:4] = np.clip(a, -1.0, 1.0) * self._rate_limit[:4]
        rates[4:] = setpoint_rates(self._hold, sim.data.qpos[sim.index.qpos[4:]],
                                   gain_per_s=float(sim.robot.setpoint_gain_per_s), rate_limit=self._rate_limit[4:])
        return rates

    def diverged(self, exc: BaseException):
        """The step's result when the world diverged (or ran out of wall-clock time): terminated, reward 0."""
        self.over = True
        sim = self.sim
        self.reading = sim.observe()
        return (self._observation(self.reading), 0.0, True, False,
                {"time_s": sim.time - self.t0, "diverged": str(exc)})

    def after_step(self, obs) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        """The step's observation, reward, ends and info once the world has stepped (the second half of :meth:`step`)."""
        step = self.account(obs)
        return self.finish(step, self._observation(obs))

    def account(self, obs, measured: tuple[float, float] | None = None) -> dict[str, Any]:
        """The bookkeeping of a step the world has taken: the reward's terms but the shaping, the
        ends, the info; rescans when a scan is due. :meth:`finish` completes it with the observation.
        ``measured``: :meth:`TrueTrench.measure <excavsim.envs.core.TrueTrench.measure>`'s numbers
        when already taken (the batched environment measures all copies at once)."""
        sim = self.sim
        self.steps += 1
        w = self.weights
        dt = sim.control_dt
        removed, over = self.truth.measure() if measured is None else measured
        spoil, load = float(sim.soil.spoil), float(sim.soil.load)
        d_removed, d_over = removed - self._measured[0], over - self._measured[1]
        d_spoil, d_load = spoil - self._spoil, load - self._load
        self._measured, self._spoil, self._load = (removed, over), spoil, load
        force = np.abs(obs.actuator_force[:4])
        saturated_mask = force >= SATURATION * self._torque_limit
        saturated = int(np.count_nonzero(saturated_mask))
        stalled = int(np.count_nonzero(saturated_mask & (np.abs(obs.qdot[:4]) < STALL_SPEED)))
        elapsed = sim.time - self.t0
        if sim.time - self._scanned_at >= self.scan_period_s - 1e-9:
            self._scan()
        terms = {"cut": 1000 * w["cut_per_l"] * d_removed, "load": 1000 * w["load_per_l"] * d_load,
                 "dump": 1000 * w["dump_per_l"] * d_spoil, "overdig": -1000 * w["overdig_per_l"] * d_over,
                 "saturation": -w["saturation_per_s"] * saturated * dt, "stall": -w["stall_per_s"] * stalled * dt,
                 "depth": 0.0, "time": -w["time_per_s"] * dt}
        terminated = bool(self._done)
        truncated = not terminated and elapsed >= self.max_time_s - 1e-9
        self.over = terminated or truncated
        info = {"time_s": elapsed, "removed_l": 1000 * removed, "overdig_l": 1000 * over,
                "spoil_l": 1000 * (spoil - self._spoil0), "load_l": 1000 * load, "saturated_joints": saturated,
                "stalled_joints": stalled, "reward_terms": terms, "map_removed_fraction": self._frac,
                "map_done": bool(self._done)}
        return {"terms": terms, "terminated": terminated, "truncated": truncated, "info": info}

    def finish(self, step: dict[str, Any], observation: dict[str, np.ndarray]
               ) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        """The step's result from :meth:`account`'s ``step`` and the observation (which set the tip's
        depth): the shaping term and the reward."""
        potential = self._depth_potential()
        terms = step["terms"]
        terms["depth"] = potential - self._potential
        self._potential = potential
        reward = sum(terms.values())
        return observation, float(reward), step["terminated"], step["truncated"], step["info"]

    def _depth_potential(self) -> float:
        """``depth_per_m`` x the tip's depth below the scanned surface inside the footprint (capped)."""
        if self._tip_inside:
            return self.weights["depth_per_m"] * min(max(self._tip_depth, 0.0), DEPTH_CAP_M)
        return 0.0

    def _observation(self, obs) -> dict[str, np.ndarray]:
        tip, pitch, wrench = self.tip_and_wrench(obs)
        terrain, goal, depth, inside = self.layout.patches(self.emap.heights[None], np.array([tip]))
        self._tip_depth, self._tip_inside = float(depth[0]), bool(inside[0])
        return {"q": np.asarray(obs.q, dtype=np.float32), "qdot": np.asarray(obs.qdot, dtype=np.float32),
                "ft": wrench.astype(np.float32),
                "tip": np.array([tip[0], tip[1], tip[2], pitch], dtype=np.float32),
                "patch": np.stack([terrain[0], goal[0]]).astype(np.float32),
                "time_left": np.array([max(self.max_time_s - (self.sim.time - self.t0), 0.0)], dtype=np.float32)}

    def tip_and_wrench(self, obs) -> tuple[tuple[float, float, float], float, np.ndarray]:
        """The tip's world position (x, y, z) [m] and pitch [rad] from the robot's kinematic model,
        and the F/T reading about the tip (6,) [N, N m] (zeros when the reading is not finite)."""
        arm = self.rig.arm
        q = obs.q
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
        return tip, pitch, wrench

    @property
    def layout(self) -> PatchLayout:
        """The height patch's geometry on this core's map and goal (valid after :meth:`reset`)."""
        e, r = self.emap, self.resolved
        key = (e.x0, e.y0, e.cell, e.heights.shape)
        if getattr(self, "_layout_key", None) != key:
            self._layout = PatchLayout(e.x0, e.y0, e.cell, e.heights.shape, self._off_x, self._off_y, r.goal,
                                       self.rig.width)
            self._layout_key = key
        return self._layout

    def close(self) -> None:
        """Free the world; a closed core cannot be reset (closing twice is fine)."""
        self.sim = None
        self.over = True
        self._closed = True


class PatchLayout:
    """The height patches of many copies of one world at once (one copy: the single environment).

    The copies share the map's grid (origin, cell, shape) and the goal; each has its own map heights
    and tip. The arithmetic is :meth:`ElevationMap.height_at <excavsim.handoff.maps.ElevationMap.height_at>`'s
    and :func:`~excavsim.handoff.goal.goal_profile`'s, element by element, so that the batched
    environment's patches equal the single one's to the bit.
    """

    def __init__(self, x0: float, y0: float, cell: float, shape: tuple[int, int], off_x: np.ndarray,
                 off_y: np.ndarray, goal, width: float):
        self.x0, self.y0, self.cell = x0, y0, cell
        self.ny, self.nx = shape
        self.off_x, self.off_y = off_x, off_y
        self.goal, self.half_width = goal, width / 2
        w = math.radians(goal.waist_deg)
        self.cw, self.sw = math.cos(w), math.sin(w)

    def heights_at(self, heights: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Bilinear heights of maps ``heights`` (N, ny, nx) at points ``x``, ``y`` (N, ...) [m]."""
        ny, nx = self.ny, self.nx
        u = np.clip((x - self.x0) / self.cell - 0.5, 0, nx - 1)
        v = np.clip((y - self.y0) / self.cell - 0.5, 0, ny - 1)
        c0 = np.minimum(u.astype(np.int64), nx - 2)
        r0 = np.minimum(v.astype(np.int64), ny - 2)
        fu, fv = u - c0, v - r0
        n = np.arange(len(heights)).reshape((-1,) + (1,) * (x.ndim - 1))
        h = heights
        return ((1 - fu) * (1 - fv) * h[n, r0, c0] + fu * (1 - fv) * h[n, r0, c0 + 1]
                + (1 - fu) * fv * h[n, r0 + 1, c0] + fu * fv * h[n, r0 + 1, c0 + 1])

    def patches(self, heights: np.ndarray, tips: np.ndarray):
        """For maps ``heights`` (N, ny, nx) and tips ``tips`` (N, 3) [m]: the terrain and goal patches
        (N, P, P) relative to the tip, the tip's depth below the map (N,) and whether the tip is
        inside the goal's footprint (N,)."""
        tx, ty, tz = tips[:, 0, None, None], tips[:, 1, None, None], tips[:, 2, None, None]
        px, py = tx + self.off_x, ty + self.off_y
        terrain = self.heights_at(heights, px, py) - tz
        g = self.goal
        radial = px * self.cw + py * self.sw
        lateral = -px * self.sw + py * self.cw
        inside = (np.abs(lateral) <= self.half_width) & (radial >= g.near_x_m) & (radial <= g.far_x_m)
        goal = np.where(inside, goal_profile(g, radial), g.surface_z_m) - tz
        t_radial = tips[:, 0] * self.cw + tips[:, 1] * self.sw
        t_lateral = -tips[:, 0] * self.sw + tips[:, 1] * self.cw
        tip_inside = (np.abs(t_lateral) <= self.half_width) & (t_radial >= g.near_x_m) & (t_radial <= g.far_x_m)
        depth = self.heights_at(heights, tips[:, 0:1], tips[:, 1:2])[:, 0] - tips[:, 2]
        return terrain, goal, depth, tip_inside


def _check_start(start: Any) -> str:
    if start not in STARTS:
        raise EnvError(f"start must be one of {', '.join(map(repr, STARTS))}; given {start!r}")
    return start


def _place_joints(sim: Simulation, q: np.ndarray) -> None:
    """Set the six joints to ``q`` [rad] at rest, with the servos' integrator states (their position
    set-points) at the same angles, and recompute the derived quantities (``mj_forward``)."""
    d, idx = sim.data, sim.index
    d.qpos[idx.qpos] = q
    d.qvel[:] = 0.0
    d.act[sim.model.actuator_actadr[idx.actuator]] = q
    d.ctrl[idx.actuator] = 0.0
    mujoco.mj_forward(sim.model, d)
