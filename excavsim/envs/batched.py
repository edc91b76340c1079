"""N copies of the joint-level world stepped together in one process: Gymnasium's ``vector_entry_point``.

:class:`BatchedJointEnv` is what ``gymnasium.make_vec(id, num_envs=N)`` gives for a joint-level id (its
default vectorization mode, or ``vectorization_mode="vector_entry_point"``). Each copy is a
:class:`~excavsim.envs.joint_core.JointCore` with its own world. Copies take the **compiled path** when their
machine's world is the servo :class:`~excavsim.world.simulation.Simulation` (no hydraulics, the wrist F/T,
four symmetric driven servos first and two held ones after: the T3) and their goal has a compiled part (its
``BATCH``, a class in the goal's own folder: the goal's measures and observation entries of all copies at
once); one step of the batch:

1. the actions of all copies are checked at once and turned into the servos' set-point rates, written
   into every copy's ``data.ctrl`` in one compiled call (:func:`servo_rates`);
2. the soil of every copy steps in **one compiled call** (:func:`soil_steps`, a loop over the
   copies around the world's own kernel :func:`~excavsim.world.kernels.soil_step`, on the same
   arrays the copies' :class:`~excavsim.world.soil.SoilModel` own), instead of one call per copy;
3. MuJoCo steps each copy's physics (``mj_step`` over the control period's substeps, the soil's
   wrench held); one compiled check (:func:`watch_ok`) passes the copies the world's watchdog would
   pass, and the watchdog itself looks at the others;
4. the goal's part measures the copies' true terrain at once (:meth:`Batch.measure`), the rewards are
   accounted per copy, and the observations of all copies are read together: the machine's entries here,
   the goal's by its part (:meth:`Batch.observe`).

The copies step exactly as N single environments do, to the bit (tests/envs/test_rl.py checks it):
the world's per-step operations on each copy are the same, in the same order. A copy whose soil uses DiMaio's model
(``truth.model: dimaio``) steps its soil on its own (the batched kernel is the wedge model's).

Any other machine or goal (an excavator's valves, the region goal) steps copy by copy through its core
(:meth:`JointCore.step <excavsim.envs.joint_core.JointCore.step>`), as ``SyncVectorEnv`` would, with the
same spaces, seeding and autoreset.

Autoreset follows Gymnasium's ``NEXT_STEP`` mode (as ``SyncVectorEnv``): the step after a copy's
episode ended resets it (its action is ignored, its reward 0) and returns its first observation.
"""

from __future__ import annotations

from typing import Any, Protocol

import gymnasium as gym
import mujoco
import numba
import numpy as np
from gymnasium.vector.utils import batch_space
from numba.typed import List

from excavsim.envs.core import EnvError, check_seed
from excavsim.envs.joint_core import JointCore
from excavsim.envs.render import RENDER_MODES, FrameRenderer, check_render_mode
from excavsim.envs.spaces import dict_space
from excavsim.handoff.observation import Diverged
from excavsim.loop.plugin import load_entry
from excavsim.world.kernels import soil_step

_OBJ_BODY = mujoco.mjtObj.mjOBJ_BODY


@numba.njit(cache=True)
def soil_steps(active, heights, strength, grids, mj_arrays, vel6, buckets, edges, surfaces, tables, rocks, params,
               dt_s, states, pressures, outs, boxes, early_out, clear):
    """One control step of the soil of every active copy: :func:`~excavsim.world.kernels.soil_step`
    on each copy's arrays (typed lists, one entry per copy; ``vel6`` (N, 6)); ``clear[i]`` is
    whether copy ``i`` took the kernel's clear-of-the-terrain early-out."""
    for i in range(len(heights)):
        if active[i]:
            clear[i] = soil_step(heights[i], strength[i], grids[i], mj_arrays[i], vel6[i], buckets[i], edges[i],
                                 surfaces[i], tables[i], rocks[i], params[i], dt_s, states[i], pressures[i], outs[i],
                                 boxes[i], early_out)


@numba.njit(cache=True)
def servo_rates(active, a, ctrls, qposs, act, qadr, hold, limit, gain):
    """The servos' set-point rates of every active copy written into its ``data.ctrl`` (typed list):
    :meth:`JointCore.checked_rates <excavsim.envs.joint_core.JointCore.checked_rates>` element by
    element for the T3's symmetric servos (the agent's four rates ``clip(a, -1, 1) * limit``, the wrist's yaw and roll driven to
    ``hold`` by the servo law of :func:`~excavsim.robot.servo.setpoint_rates`); ``a`` (N, 4) finite,
    ``act``/``qadr`` (N, 6) the actuators and joint addresses, ``hold`` (N, 2), ``limit`` (N, 6), ``gain`` (N,)."""
    for i in range(a.shape[0]):
        if not active[i]:
            continue
        ctrl, qpos = ctrls[i], qposs[i]
        for k in range(4):
            v = a[i, k]
            if v < -1.0:
                v = -1.0
            if v > 1.0:
                v = 1.0
            ctrl[act[i, k]] = v * limit[i, k]
        for k in range(4, 6):
            v = gain[i] * (hold[i, k - 4] - qpos[qadr[i, k]])
            lo, hi = -limit[i, k], limit[i, k]
            if v < lo:
                v = lo
            if v > hi:
                v = hi
            ctrl[act[i, k]] = v


@numba.njit(cache=True)
def watch_ok(stepped, counts, base, qposs, qvels, before, after, dt, half_step, ok):
    """A conservative batched watchdog: ``ok[i]`` True only where copy ``i``'s step is surely fine by
    :meth:`Simulation._watchdog <excavsim.world.simulation.Simulation._watchdog>`'s rules (no MuJoCo
    warning grew, the clock advanced by ``dt`` within ``half_step``, every joint position and
    velocity finite and below 1e300 in size, fewer than 100 of each, so that their sums are finite);
    the other copies go through the world's own watchdog, which words the reason."""
    for i in range(stepped.shape[0]):
        if not stepped[i]:
            continue
        good = abs(after[i] - before[i] - dt) <= half_step and qposs[i].shape[0] < 100 and qvels[i].shape[0] < 100
        c, b = counts[i], base[i]
        for k in range(c.shape[0]):
            if c[k] > b[k]:
                good = False
        for x in qposs[i]:
            if not abs(x) < 1e300:
                good = False
        for x in qvels[i]:
            if not abs(x) < 1e300:
                good = False
        ok[i] = good


_SOIL_LISTS = ("heights", "strength", "grids", "mj_arrays", "buckets", "edges", "surfaces", "tables", "rocks",
               "params", "states", "pressures", "outs", "boxes")


def _soil_arrays(sim) -> dict[str, Any]:
    """The arrays of a copy's soil model that its kernel reads and writes (the model's own, not copies)."""
    soil, d = sim.soil, sim.data
    return {"heights": soil.grid.heights, "strength": soil.strength, "grids": soil._grid_record,
            "mj_arrays": (d.xpos, d.xmat, d.xipos, d.site_xmat), "buckets": soil._bucket_record,
            "edges": soil._edge, "surfaces": soil._surface, "tables": soil._table, "rocks": soil.rocks,
            "params": soil.params, "states": soil._state, "pressures": soil._pressure, "outs": soil._out,
            "boxes": soil._box_body}


class Batch(Protocol):
    """A goal's part of the compiled path (the goal's ``BATCH``, made with the copies' cores): what the goal
    computes for all copies at once, with the same numbers as each copy's goal alone."""

    def attach(self, i: int) -> None:
        """Copy ``i`` was reset: point at its goal's fresh state."""

    def reset_info(self, i: int) -> dict[str, Any]:
        """Copy ``i``'s info at its reset (numbers, as the batched infos hold them)."""

    def measure(self, heights) -> list[Any] | None:
        """Every copy's true measures for :meth:`JointCore.account <excavsim.envs.joint_core.JointCore.account>`
        given their soil's heights (a typed list, one array per copy), or None (each copy measures itself)."""

    def accounted(self, i: int) -> None:
        """Copy ``i``'s goal has accounted its step (it may have rescanned)."""

    def observe(self, which: np.ndarray, readings: list[Any], out: dict[str, np.ndarray]) -> None:
        """Write the goal's entries of the observations of copies ``which`` from their ``readings`` into ``out``
        ((N, ...) float32 arrays), and leave each copy's goal as its own :meth:`observe` would."""


class BatchedJointEnv(gym.vector.VectorEnv):
    """``num_envs`` copies of :class:`~excavsim.envs.joint_env.JointEnv` stepped in one process; where the
    machine and the goal allow, the soil of all copies in one compiled call (see the module docstring).

    Spaces: the single environment's, batched (``Dict`` of (N, ...) float32 boxes; actions (N, 4)
    float32 in [-1, 1]). ``infos`` hold the single environment's numbers as (N,) arrays with
    Gymnasium's ``_name`` masks.

    Seeding: ``reset(seed=s)`` seeds copy ``i`` with ``s + i``; a list gives one seed per copy;
    without a seed the first reset uses the spec's seed plus ``i``; autoresets draw seeds from
    :attr:`np_random`.

    Args:
        num_envs: the number of copies (>= 1).
        render_mode: None or ``"rgb_array"`` (:meth:`render` gives one frame per copy).
        kwargs: as :class:`~excavsim.envs.joint_core.JointCore` (the goal, the spec or machine, weights,
            horizon, start...).
    """

    metadata = {"render_modes": list(RENDER_MODES), "autoreset_mode": gym.vector.AutoresetMode.NEXT_STEP}

    def __init__(self, num_envs: int = 4, spec=None, *, render_mode: str | None = None,
                 render_size: tuple[int, int] = (480, 360), **kwargs: Any):
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise EnvError(f"num_envs must be an integer >= 1; given {num_envs!r}")
        kwargs.pop("max_episode_steps", None)  # make_vec passes the spec's; the core ends its episodes itself
        self.num_envs = int(num_envs)
        self.render_mode = check_render_mode(render_mode)
        self.cores = [JointCore(spec, **kwargs) for _ in range(self.num_envs)]
        core = self.cores[0]
        self._batch: Batch | None = _batch_of(self.cores)
        self._compiled = self._batch is not None
        self.single_observation_space = dict_space(core.fields)
        self.single_action_space = gym.spaces.Box(-1.0, 1.0, shape=core.action_low.shape, dtype=np.float32)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.metadata = {"render_modes": list(RENDER_MODES), "autoreset_mode": gym.vector.AutoresetMode.NEXT_STEP,
                         "render_fps": round(1.0 / core.control_dt)}
        self._frames = [FrameRenderer(*render_size) for _ in range(self.num_envs)]
        self._autoreset = np.zeros(self.num_envs, dtype=bool)
        self._soil: dict[str, List] | None = None
        self._vel = np.zeros((self.num_envs, 6))
        self._clear = np.zeros(self.num_envs, dtype=np.bool_)
        self._obs: dict[str, np.ndarray] | None = None
        self._resets = 0
        # the per-copy constants of the compiled servo rates, and the views they write (set at each reset)
        self._ctrls = List([np.zeros(1)] * self.num_envs)
        self._qposs = List([np.zeros(1)] * self.num_envs)
        self._act = np.zeros((self.num_envs, 6), dtype=np.int64)
        self._qadr = np.zeros((self.num_envs, 6), dtype=np.int64)
        self._hold = np.zeros((self.num_envs, 2))
        self._limit = np.zeros((self.num_envs, 6))
        self._gain = np.zeros(self.num_envs)
        # the batched watchdog's views (set at each reset)
        self._counts: List | None = None  # typed lists of the warning counters' strided views: made at the first reset
        self._base: List | None = None
        self._qvels = List([np.zeros(1)] * self.num_envs)
        self._ok = np.zeros(self.num_envs, dtype=np.bool_)

    # -- reset ----------------------------------------------------------------------------------
    def reset(self, *, seed: int | list[int] | None = None, options: dict[str, Any] | None = None):
        """Reset every copy (see the class docstring for seeding); ``options`` go to each copy's
        :meth:`JointCore.reset <excavsim.envs.joint_core.JointCore.reset>`. Returns (observations, infos)."""
        if seed is None:
            if self._resets == 0:
                base = self.cores[0].spec.seed
                super().reset(seed=base)
                seeds = [(base + i) % 2**32 for i in range(self.num_envs)]
            else:
                super().reset()
                seeds = [int(s) for s in self.np_random.integers(0, 2**32, self.num_envs)]
        elif isinstance(seed, (list, tuple, np.ndarray)):
            if len(seed) != self.num_envs:
                raise EnvError(f"seed must be one integer or a list of {self.num_envs} (one per copy); given {seed!r}")
            seeds = [check_seed(s) for s in seed]
            super().reset(seed=seeds[0])
        else:
            check_seed(seed)
            super().reset(seed=int(seed))
            seeds = [(int(seed) + i) % 2**32 for i in range(self.num_envs)]
        self._resets += 1
        infos: dict[str, Any] = {}
        self._autoreset[:] = False
        if not self._compiled:
            firsts = [self.cores[i].reset(s, options) for i, s in enumerate(seeds)]
            for i, (_, info) in enumerate(firsts):
                infos = self._add_info(infos, info, i)
            self._obs = _stacked([obs for obs, _ in firsts])
            return self._copy_obs(), infos
        for i, s in enumerate(seeds):
            self.cores[i].reset(s, options)
            self._attach(i)
            infos = self._add_info(infos, self._batch.reset_info(i), i)
        self._obs = self._observe(np.ones(self.num_envs, dtype=bool), [c.reading for c in self.cores])
        for i in range(self.num_envs):
            self.cores[i].goal.started()
        return self._copy_obs(), infos

    def _attach(self, i: int) -> None:
        """Point the batched kernel's lists at copy ``i``'s fresh world."""
        sim = self.cores[i].sim
        arrays = _soil_arrays(sim)
        if self._soil is None:
            self._soil = {name: List([arrays[name]] * self.num_envs) for name in _SOIL_LISTS}
        else:
            for name in _SOIL_LISTS:
                self._soil[name][i] = arrays[name]
        core = self.cores[i]
        d = sim.data
        self._ctrls[i], self._qposs[i] = d.ctrl, d.qpos
        if self._counts is None:
            self._counts = List([sim._warning_view] * self.num_envs)
            self._base = List([sim._warnings] * self.num_envs)
        self._counts[i], self._base[i], self._qvels[i] = sim._warning_view, sim._warnings, d.qvel
        self._act[i], self._qadr[i] = sim._act, sim.index.qpos
        self._hold[i], self._limit[i] = core._hold, np.r_[core._hi, core._held_limit]
        self._gain[i] = core._gain
        self._batch.attach(i)

    # -- step -----------------------------------------------------------------------------------
    def step(self, actions):
        """Step every copy (resetting those whose episode ended at the last step); returns
        (observations, rewards, terminations, truncations, infos)."""
        if self._obs is None:
            raise EnvError("call reset() before step()")
        a = np.asarray(actions, dtype=np.float64)
        n = self.num_envs
        if a.shape != (n, 4):
            raise EnvError(f"actions must have shape ({n}, 4); given shape {a.shape}")
        if not np.all(np.isfinite(a)) or np.any(np.abs(a) > 1.0 + 1e-6):
            raise EnvError(f"actions must be finite rates in [-1, 1]; given {a!r}")
        if not self._compiled:
            return self._step_each(a)
        rewards = np.zeros(n)
        terminated = np.zeros(n, dtype=bool)
        truncated = np.zeros(n, dtype=bool)
        infos: dict[str, Any] = {}
        resetting = self._autoreset.copy()
        active = ~resetting
        for i in np.flatnonzero(resetting):
            self.cores[i].reset(int(self.np_random.integers(0, 2**32)))
            self._attach(i)
            infos = self._add_info(infos, self._batch.reset_info(i), i)
        soil = self._soil
        batched = np.zeros(n, dtype=bool)
        stepping = np.flatnonzero(active).tolist()  # Python ints: cheaper indices than numpy's
        cores = self.cores
        for i in stepping:
            if cores[i].over:
                raise EnvError(f"copy {i}'s episode has ended without its autoreset: call reset() first")
        servo_rates(active, a, self._ctrls, self._qposs, self._act, self._qadr, self._hold, self._limit, self._gain)
        for i in stepping:
            sim = cores[i].sim
            if sim.diverged is None and sim.soil_enabled and sim.soil.dimaio is None and sim.soil.early_out:
                mujoco.mj_objectVelocity(sim.model, sim.data, _OBJ_BODY, sim.soil._body_id, self._vel[i], 0)
                batched[i] = True
        dt = self.cores[0].sim.control_dt if n else 0.0
        soil_steps(batched, soil["heights"], soil["strength"], soil["grids"], soil["mj_arrays"], self._vel,
                   soil["buckets"], soil["edges"], soil["surfaces"], soil["tables"], soil["rocks"], soil["params"],
                   dt, soil["states"], soil["pressures"], soil["outs"], soil["boxes"], True, self._clear)
        observations: list[Any] = [None] * n
        diverged: dict[int, BaseException] = {}
        in_batch, clear = batched.tolist(), self._clear.tolist()
        before, after = np.zeros(n), np.zeros(n)
        physics = np.zeros(n, dtype=np.bool_)  # the copies MuJoCo stepped
        for i in stepping:
            sim = cores[i].sim
            try:
                _soil_done(sim, in_batch[i], clear[i])
            except Diverged as exc:
                diverged[i] = exc
                continue
            d = sim.data
            before[i] = d.time
            mujoco.mj_step(sim.model, d, sim.substeps)
            sim.steps += 1
            after[i] = d.time
            physics[i] = True
        sim0 = cores[0].sim
        watch_ok(physics, self._counts, self._base, self._qposs, self._qvels, before, after, sim0.control_dt,
                 0.5 * sim0.model.opt.timestep, self._ok)
        ok = self._ok.tolist()
        for i in np.flatnonzero(physics).tolist():
            try:
                observations[i] = _after_physics(cores[i].sim, ok[i], float(before[i]))
            except Diverged as exc:
                diverged[i] = exc
        steps: dict[int, dict[str, Any]] = {}
        batch = self._batch
        measured = batch.measure(soil["heights"])
        for i in stepping:
            core = cores[i]
            if i in diverged:
                _obs, _r, terminated[i], truncated[i], info = core.diverged(diverged[i])
                observations[i] = core.reading
                infos = self._add_info(infos, info, i)
                continue
            steps[i] = core.account(observations[i], None if measured is None else measured[i])
            batch.accounted(i)
        for i in np.flatnonzero(resetting):
            observations[i] = self.cores[i].reading
        obs = self._observe(np.ones(n, dtype=bool), observations)
        for i in np.flatnonzero(resetting):
            self.cores[i].goal.started()
        stepped = []
        for i, step in steps.items():
            _o, rewards[i], terminated[i], truncated[i], info = cores[i].finish(step, None)
            stepped.append((i, info))
        infos = self._step_infos(infos, stepped)
        self._obs = obs
        self._autoreset = terminated | truncated
        return self._copy_obs(), rewards, terminated, truncated, infos

    def _step_each(self, a: np.ndarray):
        """:meth:`step` copy by copy through each core (any machine and goal), actions ``a`` (N, 4) checked."""
        n = self.num_envs
        rewards = np.zeros(n)
        terminated = np.zeros(n, dtype=bool)
        truncated = np.zeros(n, dtype=bool)
        infos: dict[str, Any] = {}
        observations = []
        for i, core in enumerate(self.cores):
            if self._autoreset[i]:
                obs, info = core.reset(int(self.np_random.integers(0, 2**32)))
            else:
                obs, rewards[i], terminated[i], truncated[i], info = core.step(a[i])
            observations.append(obs)
            infos = self._add_info(infos, info, i)
        self._obs = _stacked(observations)
        self._autoreset = terminated | truncated
        return self._copy_obs(), rewards, terminated, truncated, infos

    def _step_infos(self, infos: dict[str, Any], stepped: list[tuple[int, dict[str, Any]]]) -> dict[str, Any]:
        """The stepped copies' infos as (N,) arrays with their ``_name`` masks, built directly (the
        base class's ``_add_info``, copy by copy, costs more than a copy's soil step); the copies that
        were reset or diverged this step have theirs added over them."""
        if not stepped:
            return infos
        n = self.num_envs
        mask = np.zeros(n, dtype=bool)
        index = [i for i, _ in stepped]
        mask[index] = True
        out: dict[str, Any] = {}
        first = stepped[0][1]
        for key, value in first.items():
            if key == "reward_terms":
                terms = {}
                for term in value:
                    arr = np.zeros(n)
                    arr[index] = [info["reward_terms"][term] for _, info in stepped]
                    terms[term], terms[f"_{term}"] = arr, mask.copy()
                out[key], out[f"_{key}"] = terms, mask.copy()
                continue
            arr = np.zeros(n, dtype=bool if isinstance(value, bool) else
                           np.int64 if isinstance(value, int) else np.float64)
            arr[index] = [info[key] for _, info in stepped]
            out[key], out[f"_{key}"] = arr, mask.copy()
        for key, value in infos.items():  # reset or diverged copies, added before
            if key.startswith("_") or key not in out or isinstance(value, dict):
                out.setdefault(key, value)
                continue
            m = infos[f"_{key}"]
            out[key] = out[key].astype(np.result_type(out[key], value))
            out[key][m] = value[m]
            out[f"_{key}"] = out[f"_{key}"] | m
        return out

    def _observe(self, which: np.ndarray, observations: list[Any]) -> dict[str, np.ndarray]:
        """The observations of all copies (the single environment's, computed together): the machine's
        entries here, the goal's by its part of the compiled path."""
        n = self.num_envs
        core0 = self.cores[0]
        out = {name: np.zeros((n,) + f.shape, np.float32) for name, f in core0.fields.items()}
        m = core0.machine  # the joints' bounds, as the single observation clips them
        joints = len(m.joints)
        q, qdot, ft = np.zeros((n, joints)), np.zeros((n, joints)), np.zeros((n, 6))
        for i in np.flatnonzero(which).tolist():  # gathered in float64, cast to float32 once per field
            core, obs = self.cores[i], observations[i]
            q[i] = obs.q
            qdot[i] = obs.qdot
            ft[i] = core.wrench(obs)
        out["q"][:] = np.clip(q, -m.angle_bound_rad, m.angle_bound_rad)
        out["qdot"][:] = np.clip(qdot, -m.speed_bound_rad_s, m.speed_bound_rad_s)
        out["ft"][:] = ft
        self._batch.observe(which, observations, out)
        return out

    def _copy_obs(self) -> dict[str, np.ndarray]:
        return {k: v.copy() for k, v in self._obs.items()}

    def render(self):
        """One frame per copy (a tuple) with ``render_mode="rgb_array"``; None without a render mode."""
        if self.render_mode is None or self.cores[0].sim is None:
            return None
        return tuple(f.render(c.sim.model, c.sim.data) for f, c in zip(self._frames, self.cores))

    def close_extras(self, **kwargs: Any) -> None:
        """Free the worlds and the renderers."""
        for f in self._frames:
            f.close()
        for c in self.cores:
            c.close()


def _soil_done(sim, batched: bool, clear: bool) -> None:
    """The first part of :meth:`Simulation.step <excavsim.world.simulation.Simulation.step>` once the
    copy's soil kernel has run in the batch (``batched``; otherwise the soil steps here, on its own):
    the soil's bookkeeping and its wrench held on the bucket. With :func:`_after_physics` around
    MuJoCo's substeps: the same operations in the same order as ``Simulation.step``."""
    d = sim.data
    if sim.diverged is not None:
        raise Diverged(f"the simulation diverged earlier and cannot go on: {sim.diverged}")
    if sim.soil_enabled:
        if batched:
            sim.soil.clear_steps += int(clear)
            sim.contact = sim.soil._after_step(d, sim.control_dt)
        else:
            sim.contact = sim.soil.step(d, sim.control_dt)
        sim._xfrc_bucket[:] = sim.contact.wrench
    else:
        sim._xfrc_bucket[:] = 0.0


def _after_physics(sim, ok: bool, before: float):
    """The rest of ``Simulation.step`` after MuJoCo's substeps from time ``before``: the world's
    watchdog unless the batched check (:func:`watch_ok`) found the step fine, the clock, the step
    hooks and the observation."""
    if not ok:
        why = sim._watchdog(before)
        if why is not None:
            sim.diverged = f"{why} in the control step from t = {sim._clock:.3f} s (step {sim.steps})"
            raise Diverged(f"the simulation diverged: {sim.diverged}")
    sim._clock = float(sim.data.time)
    for hook in sim.step_hooks:
        hook(sim)
    return sim.observe()


def _batch_of(cores: list[JointCore]) -> Batch | None:
    """The goal's part of the compiled path for copies ``cores``, or None when they step copy by copy: the
    compiled path needs a goal with a ``BATCH`` and a machine whose world is the servo
    :class:`~excavsim.world.simulation.Simulation` (no hydraulics) with the wrist F/T, its four driven servos
    first and two held ones after (the layout :func:`servo_rates` writes); its servos' ranges are symmetric
    (the robot configuration's flow limits, :func:`~excavsim.world.scene.build_physics`), so that
    ``a * limit`` is the core's rate for either sign."""
    core = cores[0]
    m = core.machine
    entry = getattr(type(core.goal), "BATCH", None)
    if (entry is None or m.hydraulics is not None or m.force_reading != "ft" or core.driven.tolist() != [0, 1, 2, 3]
            or core.held.tolist() != [4, 5]):
        return None
    return load_entry(entry)(cores)


def _stacked(observations: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """The copies' observations as one dict of (N, ...) arrays."""
    return {k: np.stack([o[k] for o in observations]) for k in observations[0]}


__all__ = ["Batch", "BatchedJointEnv", "servo_rates", "soil_steps", "watch_ok"]
