"""The joint-level trench goal: dig the spec's trench, seen through scanned maps (``excavsim/TrenchJoint*``).

:class:`JointTrench` is one of :class:`~excavsim.envs.joint_core.JointCore`'s goals, the trench task's
(named by its entry point :data:`~excavsim.tasks.trench.envs.JOINT_GOAL` in the ids' keywords): the start
over the trench, the height patch around the tip, the reward on the true trench, the ends and the clock. It
runs on any trenching machine (the spec's ``machine``): the trench goal is resolved in that machine's pit,
and the loop's pieces around it (the scanner and the machine's model of itself,
:func:`~excavsim.rig.core.make_rig`) are that machine's. The true trench it shares with the dig level is
:class:`~excavsim.tasks.trench.envs.core.TrueTrench`; its part of the batched environment's compiled path
is :class:`~excavsim.tasks.trench.envs.batched.TrenchBatch`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from excavsim.envs.core import EnvError, Field
from excavsim.handoff.goal import goal_profile
from excavsim.rig.core import go_home, make_rig, scan
from excavsim.rig.measures import trench_footprint
from excavsim.robot.fast import arm_params, forward_pose
from excavsim.tasks.trench.envs.core import TrueTrench
from excavsim.tasks.trench.plugin import NAME
from excavsim.tasks.trench.task import map_done

JOINT_WEIGHTS = {"cut_per_l": 1.0, "load_per_l": 0.5, "dump_per_l": 1.0, "overdig_per_l": 2.0,
                 "saturation_per_s": 1.0, "stall_per_s": 2.0, "depth_per_m": 10.0, "time_per_s": 0.0}
"""The trench goal's default reward weights (each term in :class:`JointTrench`'s docstring): per litre
removed above the goal inside its footprint, per litre gained in the bucket, per litre dumped to the
spoil, per litre dug below the goal profile, per second of each driven joint at its relief limit, per
second of each driven joint stalled there, the potential's slope per metre of the tip below the scanned
surface inside the footprint, per second of the episode."""
SATURATION = 0.97  # a joint at this fraction of its relief limit counts as saturated (the executor's stall level)
STALL_SPEED = 0.02  # a saturated joint slower than this [rad/s] is stalled
DEPTH_CAP_M = 0.3  # the shaping potential's depth saturates here [m]
STARTS = ("home", "near_soil")
START_OPTIONS = ("start", "start_x_m", "start_height_m", "start_pitch_deg")
"""The reset options the trench goal takes."""


class JointTrench:
    """The spec's trench, dug at the joint level (the goal ``trench`` of
    :class:`~excavsim.envs.joint_core.JointCore`, the trench task's).

    Its observation entries (float32, after the machine's): ``tip``, the bucket tip's pose from the machine's
    own kinematic model (x, y, z [m] in the world and pitch [rad]); ``patch``, a local height patch around
    the tip from the **scanned elevation map**, rescanned every ``scan_period_s`` of simulated time
    (``math.inf``: only at reset, as the loop scans before each dig; the scanner's rays see the soil only, so
    the arm does not hide it; between scans the patch is the last map's), beside the goal's height at the
    same points, both relative to the tip; and ``time_left`` [s].

    The start (``start``, or the reset option of that name): ``"home"``, the machine moved to its trenching
    ``home`` pose (the model's keyframe, or the machine's own) over the soil; ``"near_soil"``, the tip placed
    by the machine's inverse kinematics in the goal's arm plane ``start_height_m`` above the goal's surface
    at radial distance ``start_x_m`` with pitch ``start_pitch_deg``, each drawn from the episode's seed when
    not given (x uniform over the far 60 % of the trench's opening, height uniform in [0.01, 0.06] m, pitch
    60 deg), the machine set there at rest (no simulated move; the world's ``place``, with an excavator's
    servos set to hold it against its droop).

    Reward per step, on the true terrain (privileged), the sum of these terms (``info["reward_terms"]``):

    * ``cut``: ``cut_per_l`` x litres newly removed above the goal profile inside its footprint;
    * ``load``: ``load_per_l`` x litres gained in the bucket (negative when soil leaves it);
    * ``dump``: ``dump_per_l`` x litres newly dumped to the spoil (out of the box);
    * ``overdig``: -``overdig_per_l`` x litres newly dug below the goal profile;
    * ``saturation``: -``saturation_per_s`` x seconds x driven joints at 97 % of their relief torque (the
      T3's servos' constant one, an excavator's at the pose in the direction it pushes);
    * ``stall``: -``stall_per_s`` x seconds x those joints also slower than 0.02 rad/s;
    * ``depth``: potential-based shaping (Ng et al. 1999, with discount 1): the change of
      ``depth_per_m`` x the tip's depth below the scanned surface (capped at 0.3 m; 0 outside the
      goal's footprint), so that an episode's shaping sums to its last potential less its first and
      holding still earns nothing;
    * ``time``: -``time_per_s`` x seconds.

    The episode terminates when a scan shows the trench within tolerance (the loop's done rule) or the
    world diverges, and is truncated after ``max_time_s`` of simulated time (the world's clock).

    Args:
        core: the core it is the goal of.
        scan_period_s: simulated time between scans [s]; ``math.inf`` scans only at reset.
        patch_size, patch_spacing_m: the height patch, ``patch_size`` x ``patch_size`` points
            ``patch_spacing_m`` apart centred under the tip, in world axes.
        start: ``"home"`` or ``"near_soil"`` (above); the reset option overrides it.
    """

    NAME = NAME
    TASK = NAME  # the spec is the trench task's (its goal, machine, soil and configuration overrides)
    WEIGHTS = JOINT_WEIGHTS
    MAX_TIME_S = 60.0
    SPEC_DEFAULTS: dict[str, Any] = {}
    OPTIONS = ("scan_period_s", "patch_size", "patch_spacing_m", "start")
    READS_TORQUES = True  # the saturation terms read the joints' torques
    BATCH = "excavsim.tasks.trench.envs.batched:TrenchBatch"  # the compiled path of the batched environment

    def __init__(self, core, *, scan_period_s: float = 1.0, patch_size: int = 9, patch_spacing_m: float = 0.1,
                 start: str = "home"):
        for name, v in (("scan_period_s", scan_period_s), ("patch_spacing_m", patch_spacing_m)):
            if isinstance(v, bool) or not (isinstance(v, (int, float)) and v > 0 and not math.isnan(v)) or (
                    name != "scan_period_s" and not math.isfinite(v)):
                allowed = "a number > 0 (math.inf: only at reset)" if name == "scan_period_s" else "a finite number > 0"
                raise EnvError(f"{name} must be {allowed}; given {v!r}")
        if isinstance(patch_size, bool) or not isinstance(patch_size, int) or not 1 <= patch_size <= 101:
            raise EnvError(f"patch_size must be an integer from 1 to 101; given {patch_size!r}")
        self.core = core
        self.start_default = _check_start(start)
        self.scan_period_s = float(scan_period_s)
        self.patch_size, self.patch_spacing_m = patch_size, float(patch_spacing_m)
        off = (np.arange(patch_size) - (patch_size - 1) / 2) * self.patch_spacing_m
        self._off_x, self._off_y = np.meshgrid(off, off)
        goal = core.resolved.goal
        x = (goal.near_x_m + goal.far_x_m) / 2
        w = math.radians(goal.waist_deg)
        self.lookat = (x * math.cos(w), x * math.sin(w), goal.surface_z_m)
        """Where a camera looks: the trench's middle on the surface [m]."""

    def fields(self) -> dict[str, Field]:
        """The goal's observation entries (the table's extent bounds the tip on a large machine)."""
        t = self.core.machine.table
        tip_bound = max(10.0, t.x_max_m + 1.0, t.z_max_m + 1.0)
        patch_bound = max(5.0, t.z_max_m - t.z_min_m + 1.0)
        p = self.patch_size
        return {
            "tip": Field((4,), "float32", -tip_bound, tip_bound, doc="bucket tip x, y, z [m] (world) and pitch [rad]"),
            "patch": Field((2, p, p), "float32", -patch_bound, patch_bound,
                           doc="scanned terrain and goal heights around the tip, relative to the tip [m]"),
            "time_left": Field((1,), "float32", 0.0, self.core.max_time_s, doc="simulated time left [s]"),
        }

    # -- reset ----------------------------------------------------------------------------------
    def start(self, seed: int, options: Mapping[str, Any] | None) -> tuple[float, float, float] | None:
        """The start's tip pose (x, z, pitch) in the arm plane [m, m, rad], or None for home.

        Raises:
            EnvError: an unknown option, or a value out of its range.
        """
        options = dict(options or {})
        unknown = sorted(set(options) - set(START_OPTIONS))
        if unknown:
            raise EnvError(f"unknown reset option(s) {unknown}; allowed: {', '.join(START_OPTIONS)}")
        start = _check_start(options.get("start", self.start_default))
        if start == "home":
            extra = sorted(set(options) - {"start"})
            if extra:
                raise EnvError(f"reset options {extra} need start='near_soil'; given start='home'")
            return None
        g = self.core.resolved.goal
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

    def reset(self, sim, seed: int, start: tuple[float, float, float] | None) -> dict[str, Any]:
        """The loop's pieces on the fresh world ``sim``, the machine at ``start``, a first scan; the reset's info."""
        core = self.core
        r = core.resolved
        self.rig = rig = make_rig(sim, seed=seed, goal=r.goal, planner_cfg=r.planner, executor_cfg=r.executor,
                                  sensing_cfg=r.sensing, machine=core.machine)
        mask, z_goal = trench_footprint(sim, r.goal, rig.width)
        self.truth = TrueTrench(sim, mask, z_goal - sim.soil.grid.z0)  # the grid's heights are above its floor
        self._waist = math.radians(r.goal.waist_deg)
        if start is None:
            go_home(sim, rig)
        else:
            self._place(start)
        self._arm_params = arm_params(rig.arm)
        self._scan()
        self.t0 = sim.time
        self._measured = self.truth.measure()
        self._spoil = self._spoil0 = float(sim.soil.spoil)
        self._load = float(sim.soil.load)
        return {"time_s": 0.0, "map_removed_fraction": self._frac, "map_done": self._done,
                "start": "home" if start is None else "near_soil",
                "start_pose": None if start is None else np.array(start)}

    def _place(self, pose: tuple[float, float, float]) -> None:
        """Set the machine at rest with its tip at ``pose`` (x, z, pitch) in the goal's arm plane, the held
        joints at their home angles, the servos holding it there (an excavator's cylinders' set-points raised
        by their droop under the arm's weight, :class:`~excavsim.execution.droop.DroopCompensation`)."""
        rig = self.rig
        q_arm, ok = rig.arm.inverse(np.asarray(pose, dtype=float))
        if not bool(np.all(ok)) or not np.all(np.isfinite(q_arm)):
            raise EnvError(f"the start pose (x {pose[0]:.3f} m, z {pose[1]:.3f} m, pitch "
                           f"{math.degrees(pose[2]):.1f} deg) is out of the {self.core.machine.name}'s reach")
        q = rig.home.copy()
        driven = self.core.driven
        q[driven[0]] = rig.arm.waist_sign * self._waist
        q[driven[1:]] = q_arm
        rig.executor.sim.place(q)  # the executor's servos: the world's, or with an excavator's droop fed forward

    def _scan(self) -> None:
        core = self.core
        r = core.resolved
        self.emap, _ = scan(core.sim, self.rig)
        self._scanned_at = core.sim.time
        self._done, self._frac = map_done(self.emap, r.goal, self.rig.arm, self.rig.width,
                                          done_fraction=core.spec.options.done_fraction,
                                          tolerance_m=core.spec.options.tolerance_m,
                                          initial_z=r.goal.surface_z_m)
        self._frac = float(self._frac)

    def started(self) -> None:
        """The shaping's first potential, once the first observation set the tip's depth."""
        self._potential = self._depth_potential()

    def elapsed(self) -> float:
        """Simulated time since the start [s]."""
        return self.core.sim.time - self.t0

    # -- step -----------------------------------------------------------------------------------
    def account(self, reading, measured: tuple[float, float] | None = None) -> dict[str, Any]:
        """The reward's terms but the shaping, the ends and the info of a step the world has taken; rescans
        when a scan is due. ``measured``: :meth:`TrueTrench.measure <excavsim.tasks.trench.envs.core.TrueTrench.measure>`'s
        numbers when already taken."""
        core = self.core
        sim = core.sim
        w = core.weights
        dt = sim.control_dt
        removed, over = self.truth.measure() if measured is None else measured
        spoil, load = float(sim.soil.spoil), float(sim.soil.load)
        d_removed, d_over = removed - self._measured[0], over - self._measured[1]
        d_spoil, d_load = spoil - self._spoil, load - self._load
        self._measured, self._spoil, self._load = (removed, over), spoil, load
        driven = core.driven
        force = np.abs(reading.actuator_force[driven])
        saturated_mask = force >= SATURATION * sim.torque_limit[driven]
        saturated = int(np.count_nonzero(saturated_mask))
        stalled = int(np.count_nonzero(saturated_mask & (np.abs(reading.qdot[driven]) < STALL_SPEED)))
        elapsed = sim.time - self.t0
        if sim.time - self._scanned_at >= self.scan_period_s - 1e-9:
            self._scan()
        terms = {"cut": 1000 * w["cut_per_l"] * d_removed, "load": 1000 * w["load_per_l"] * d_load,
                 "dump": 1000 * w["dump_per_l"] * d_spoil, "overdig": -1000 * w["overdig_per_l"] * d_over,
                 "saturation": -w["saturation_per_s"] * saturated * dt, "stall": -w["stall_per_s"] * stalled * dt,
                 "depth": 0.0, "time": -w["time_per_s"] * dt}
        terminated = bool(self._done)
        truncated = not terminated and elapsed >= core.max_time_s - 1e-9
        info = {"time_s": elapsed, "removed_l": 1000 * removed, "overdig_l": 1000 * over,
                "spoil_l": 1000 * (spoil - self._spoil0), "load_l": 1000 * load, "saturated_joints": saturated,
                "stalled_joints": stalled, "reward_terms": terms, "map_removed_fraction": self._frac,
                "map_done": bool(self._done)}
        return {"terms": terms, "terminated": terminated, "truncated": truncated, "info": info}

    def finish(self, terms: dict[str, float]) -> None:
        """The shaping term, from the tip's depth the observation just read."""
        potential = self._depth_potential()
        terms["depth"] = potential - self._potential
        self._potential = potential

    def _depth_potential(self) -> float:
        """``depth_per_m`` x the tip's depth below the scanned surface inside the footprint (capped)."""
        if self._tip_inside:
            return self.core.weights["depth_per_m"] * min(max(self._tip_depth, 0.0), DEPTH_CAP_M)
        return 0.0

    # -- observation ----------------------------------------------------------------------------
    def observe(self, reading) -> dict[str, np.ndarray]:
        """The goal's entries of the observation of ``reading`` (and the tip's depth for the shaping)."""
        tip, pitch = self.tip(reading)
        terrain, goal, depth, inside = self.layout.patches(self.emap.heights[None], np.array([tip]))
        self._tip_depth, self._tip_inside = float(depth[0]), bool(inside[0])
        return {"tip": np.array([tip[0], tip[1], tip[2], pitch], dtype=np.float32),
                "patch": np.stack([terrain[0], goal[0]]).astype(np.float32),
                "time_left": np.array([max(self.core.max_time_s - self.elapsed(), 0.0)], dtype=np.float32)}

    def tip(self, reading) -> tuple[tuple[float, float, float], float]:
        """The tip's world position (x, y, z) [m] and pitch [rad] from the machine's kinematic model."""
        arm = self.rig.arm
        q = reading.q
        d = self.core.driven
        x, z, pitch = forward_pose(self._arm_params, float(q[d[1]]), float(q[d[2]]), float(q[d[3]]))
        phi = arm.waist_sign * float(q[d[0]])  # PlanarArm.plane_to_world, on scalars
        c, s = math.cos(phi), math.sin(phi)
        y0 = arm.plane_offset_y
        return (arm.waist_axis_xy[0] + c * x - s * y0, arm.waist_axis_xy[1] + s * x + c * y0, z), pitch

    @property
    def layout(self) -> PatchLayout:
        """The height patch's geometry on this goal's map (valid after :meth:`reset`)."""
        e = self.emap
        key = (e.x0, e.y0, e.cell, e.heights.shape)
        if getattr(self, "_layout_key", None) != key:
            self._layout = PatchLayout(e.x0, e.y0, e.cell, e.heights.shape, self._off_x, self._off_y,
                                       self.core.resolved.goal, self.rig.width)
            self._layout_key = key
        return self._layout


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
