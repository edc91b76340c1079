"""The joint-level environments' core: any trenching machine at its control rate, free of any RL library.

:class:`JointCore` is the core of ``excavsim/TrenchJoint-v0``, ``excavsim/TrenchJointDig-v0`` and
``excavsim/ExcavatorJoint-v0`` (its Gymnasium face is :class:`~excavsim.envs.joint_env.JointEnv`, its
dm_env face :class:`~excavsim.envs.dm.DmJoint`, its batched vector face
:class:`~excavsim.envs.batched.BatchedJointEnv`). It runs every machine of :mod:`excavsim.robot.machine`
(the T3, ``tb035``, ``excavator_25t``); what differs is data, not code:

* **the machine's** (its :class:`~excavsim.robot.machine.Machine` and its model): the world that steps it
  (:func:`~excavsim.world.machines.make_world`); the four joints the agent drives (the waist or swing and the
  planar three) and those held still (the T3's wrist yaw and roll, driven to their ``home`` angles by the
  servo law); each actuator's range of set-point rates (the model's ``ctrlrange``: the T3's servos' flow
  limits, an excavator's valves' swing and cylinder speeds); the pumps that share their flow between
  functions (a machine with hydraulics, Rowe 1997 §4.0); how it senses force (the wrist F/T about the tip, or
  the cylinders' pressures) and the bounds of its readings;
* **the goal's**: the start, what is observed of the task, the reward, the ends and the clock. A goal is
  a class (:class:`JointGoal`'s protocol) named by its entry point ``module:Class`` (what an environment
  id's ``goal`` keyword holds) or by a name of :func:`joint_goals`: each task's own (the goal of the
  joint-level environments its plug-in contributes, named as the task: a trench goal seen through
  scanned maps, in the trench task's folder) and the platform's ``region``
  (:class:`~excavsim.envs.joint_region.JointRegion`, a box of the pit in front of an excavator, privileged).

One step: the action (4,) in [-1, 1] becomes the actuators' set-point rates (:meth:`JointCore.checked_rates`:
arrays in, arrays out, no branch on the values), the world steps one control period, the goal accounts the
step and the observation is read. The observation is the machine's proprioception, ``q`` and ``qdot`` (every
joint's angle [rad] and speed [rad/s]) and its force reading (``ft`` or ``cylinder_force``), then the goal's
entries.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, ClassVar, NamedTuple, Protocol

import mujoco
import numpy as np

from excavsim.config import parse_config
from excavsim.envs.core import EnvError, Field, as_spec, check_seed, check_vector, check_weights
from excavsim.errors import ConfigError, ExcavsimError
from excavsim.handoff.observation import Diverged, OutOfTime
from excavsim.loop import catalog
from excavsim.loop.plugin import load_entry
from excavsim.loop.scenario import EpisodeSpec, resolve
from excavsim.readouts import element_id, keyframe_qpos
from excavsim.robot.cylinders import share_pump_flow
from excavsim.robot.excavators import PUMPS
from excavsim.robot.machine import Machine, get_machine
from excavsim.robot.servo import setpoint_rates
from excavsim.sensing.ft import ForceSensor
from excavsim.world.hydraulics import CONTROL_RATE_HZ as HYDRAULIC_RATE_HZ
from excavsim.world.machines import make_world

JOINT_ENTRY_POINT = "excavsim.envs.joint_env:JointEnv"
"""The joint-level environment's Gymnasium face, by entry point (every joint-level id registers it)."""
PLATFORM_GOALS = {"region": "excavsim.envs.joint_region:JointRegion"}
"""The joint-level goals of no task, by name: entry points ``module:Class``."""
SPEC_KEYWORDS = ("machine", "soil", "seed")
"""The spec's fields :class:`JointCore` also takes as keywords (they override the spec's)."""


class JointGoal(Protocol):
    """What :class:`JointCore` asks of its goal: what an episode starts from, observes of its task, is rewarded
    for and ends on (:class:`~excavsim.envs.joint_region.JointRegion` is one).

    Class attributes: ``NAME`` (for messages), ``TASK`` (the task whose episode specification configures the
    world: its machine, soil and configuration files), ``WEIGHTS`` (the reward's default weights),
    ``MAX_TIME_S`` (the default episode length [s]), ``SPEC_DEFAULTS`` (the spec's fields it sets when neither
    the spec nor a keyword does), ``OPTIONS`` (its settings, keywords of the core), ``READS_TORQUES`` (whether
    it reads the world's full sensor reading) and ``BATCH`` (None, or the entry point of the goal's part of
    the batched environment's compiled path, :mod:`excavsim.envs.batched`). ``lookat`` is where a camera
    looks [m]."""

    NAME: ClassVar[str]
    TASK: ClassVar[str]
    WEIGHTS: ClassVar[Mapping[str, float]]
    MAX_TIME_S: ClassVar[float]
    SPEC_DEFAULTS: ClassVar[Mapping[str, Any]]
    OPTIONS: ClassVar[tuple[str, ...]]
    READS_TORQUES: ClassVar[bool]
    BATCH: ClassVar[str | None]
    lookat: tuple[float, float, float]

    def fields(self) -> dict[str, Field]: ...
    def start(self, seed: int, options: Mapping[str, Any] | None) -> Any: ...
    def reset(self, sim, seed: int, start: Any) -> dict[str, Any]: ...
    def started(self) -> None: ...
    def elapsed(self) -> float: ...
    def account(self, reading, measured: Any = None) -> dict[str, Any]: ...
    def finish(self, terms: dict[str, float]) -> None: ...
    def observe(self, reading) -> dict[str, np.ndarray]: ...


def joint_goals() -> dict[str, str]:
    """Every joint-level goal by name, as entry points ``module:Class``: each task's (the ``goal`` of the first
    joint-level environment its plug-in contributes, named as the task), then :data:`PLATFORM_GOALS`."""
    goals: dict[str, str] = {}
    for name, plugin in catalog.plugins().items():
        for env in plugin.environments:
            goal = env.kwargs.get("goal")
            if env.entry_point == JOINT_ENTRY_POINT and isinstance(goal, str) and ":" in goal:
                goals.setdefault(name, goal)
    return {**goals, **PLATFORM_GOALS}


def goal_class(goal: str | type | None) -> type:
    """The goal class ``goal`` stands for: itself (a class), an entry point ``module:Class``, or a name of
    :func:`joint_goals` (None: the default task's, :data:`~excavsim.loop.catalog.DEFAULT_TASK`).

    Raises:
        EnvError: an unknown name, or an entry point that cannot be loaded or is not a class.
    """
    if isinstance(goal, type):
        return goal
    if goal is None:
        goal = catalog.DEFAULT_TASK
    if not isinstance(goal, str):
        raise EnvError(f"goal must be a name, an entry point module:Class or a goal class; given {goal!r}")
    entry = goal
    if ":" not in goal:
        names = joint_goals()
        if goal not in names:
            raise EnvError(f"goal must be one of {', '.join(map(repr, names))} or an entry point module:Class; "
                           f"given {goal!r} (what a task's episode digs is its spec's own field)")
        entry = names[goal]
    try:
        found = load_entry(entry)
    except ConfigError as exc:
        raise EnvError(f"goal {goal!r}: {exc}") from None
    if not isinstance(found, type):
        raise EnvError(f"goal {goal!r} is not a class; allowed: a goal class (excavsim.envs.joint_core.JointGoal)")
    return found


class Encoders(NamedTuple):
    """The joint encoders alone (every joint's angle [rad] and speed [rad/s]): what the core reads of the world
    when neither the machine's force reading nor the goal needs its full sensor reading (an excavator's joint
    torques cost more than its whole step without soil)."""

    q: np.ndarray
    qdot: np.ndarray


class JointCore:
    """A trenching machine at its control rate: the agent drives its four digging joints' set-point rates.

    The action is four numbers in [-1, 1], one per driven joint (the waist or swing, then the planar three:
    shoulder or boom, elbow or stick, wrist pitch or bucket), each that actuator's set-point rate as a
    fraction of its range: positive towards the upper end of the model's ``ctrlrange``, negative towards the
    lower (the T3's servos are symmetric; an excavator's cylinders extend, boom up and stick and bucket in,
    faster than they retract). On a machine with hydraulics the pumps' flow is then shared between the
    functions on one pump (:func:`~excavsim.robot.cylinders.share_pump_flow`). Held joints (the T3's wrist
    yaw and roll) are driven to their ``home`` angles. One step is one control period of the machine's world
    (the T3's 10 ms, an excavator's 20 ms).

    The observation (all float32): ``q`` and ``qdot``, every joint's encoder angle [rad] and speed [rad/s]
    within the machine's bounds (:attr:`~excavsim.robot.machine.Machine.angle_bound_rad`,
    :attr:`~excavsim.robot.machine.Machine.speed_bound_rad_s`; clipped to them); the machine's force reading:
    ``ft`` (6,), the wrist F/T as the robot's sensor reports it (the soil's force [N] and moment [N m] on the
    bucket about its tip, in the tip frame; zeros when the reading is not finite), or ``cylinder_force`` (4,),
    the swing torque [N m] and the three cylinder forces [N] (the pressure transducers' reading, positive
    pushing, clipped to the relief limits); then the goal's entries (see its class).

    Args:
        spec: the world (machine, soil, seed, the task's own fields such as a trench goal, configuration
            overrides), an episode specification of the goal's ``TASK`` (see
            :func:`~excavsim.envs.core.as_spec`); its dig budget is not used.
        goal: the goal (:func:`goal_class`): a class, its entry point ``module:Class``, or a name of
            :func:`joint_goals`; None: the default task's goal.
        machine, soil, seed: the spec's fields of those names (when given, they override the spec's); a
            field neither gives takes the goal's default (the region's: the TB035 in dry sand), else the spec's.
        weights: reward weights over the goal's ``WEIGHTS``.
        max_time_s: the episode's length in simulated time [s] (default: the goal's ``MAX_TIME_S``).
        robot_path, scene_path: other robot and scene configurations (``configs/robot.yaml``, ``scene.yaml``).
        options: the goal's own settings (its ``OPTIONS``: the trench goal's ``scan_period_s``, ``patch_size``,
            ``patch_spacing_m``, ``start``; the region has none).

    Raises:
        EnvError: an unknown goal or goal setting, a bad weight or time, a machine the goal has no place for.
        ConfigError: the spec (with the keywords) is not valid, e.g. an unknown machine.
    """

    def __init__(self, spec=None, *, goal: str | type | None = None, machine: str | None = None,
                 soil: str | None = None, seed: int | None = None, weights: Mapping[str, float] | None = None,
                 max_time_s: float | None = None, robot_path=None, scene_path=None, **options: Any):
        kind = goal_class(goal)
        self.spec = _with_fields(as_spec(spec, kind.TASK), kind, {"machine": machine, "soil": soil, "seed": seed})
        self.machine: Machine = get_machine(self.spec.machine_name)
        self.resolved = resolve(self.spec, robot_path=robot_path, scene_path=scene_path)
        self.weights = check_weights(weights, kind.WEIGHTS, kind.NAME)
        max_time_s = kind.MAX_TIME_S if max_time_s is None else max_time_s
        if isinstance(max_time_s, bool) or not isinstance(max_time_s, (int, float)) or not (
                math.isfinite(max_time_s) and max_time_s > 0):
            raise EnvError(f"max_time_s must be a finite number > 0; given {max_time_s!r}")
        self.max_time_s = float(max_time_s)
        m = self.machine
        self.driven = np.array(m.index((m.waist, *m.planar)))
        """(4,) the driven joints' positions in the machine's joint order."""
        self.held = np.array(m.index([name for name, _ in m.held]), dtype=np.int64)
        """The held joints' positions in the machine's joint order."""
        self.action_low, self.action_high = -np.ones(len(self.driven)), np.ones(len(self.driven))
        self.control_dt = 1.0 / (self.resolved.robot.control_rate_hz if m.hydraulics is None
                                 else HYDRAULIC_RATE_HZ)  # refined by the world at reset
        unknown = sorted(set(options) - set(kind.OPTIONS))
        if unknown:
            raise EnvError(f"unknown setting(s) {unknown} of the {kind.NAME} goal; allowed: "
                           f"{', '.join(kind.OPTIONS) or 'none'} (and JointCore's own keywords)")
        machine_fields = self._machine_fields()
        self.goal: JointGoal = kind(self, **options)
        self.fields = {**machine_fields, **self.goal.fields()}
        self._observes = m.force_reading == "ft" or kind.READS_TORQUES  # what :meth:`read` reads
        self.sim = None
        self.reading = None
        self.over = True
        self.steps = 0
        self._closed = False

    def _machine_fields(self) -> dict[str, Field]:
        """The machine's proprioception: joint angles and speeds, and its force reading."""
        m = self.machine
        n = len(m.joints)
        names = ", ".join(j.removesuffix("_joint").replace("_", " ") for j in m.joints)
        fields = {"q": Field((n,), "float32", -m.angle_bound_rad, m.angle_bound_rad, doc=f"{names} angles [rad]"),
                  "qdot": Field((n,), "float32", -m.speed_bound_rad_s, m.speed_bound_rad_s,
                                doc="their speeds [rad/s]")}
        if m.force_reading == "cylinders":
            model = mujoco.MjModel.from_xml_path(str(m.hydraulics.scene_xml))
            flim = np.abs(model.actuator_forcerange[_actuators(model, m)])
            self.force_low, self.force_high = -flim[:, 0], flim[:, 1]  # [N, N m]
            fmax = float(flim.max())  # the largest relief force (or swing torque)
            fields["cylinder_force"] = Field((n,), "float32", -fmax, fmax,
                                             doc=f"{names.split(', ')[0]} torque [N m], the cylinder forces [N] "
                                                 "(+ pushes; each within its relief limits)")
        else:
            fields["ft"] = Field((6,), "float32", -1e6, 1e6,
                                 doc="F/T: soil force [N] and moment [N m] on the bucket, tip frame")
        return fields

    # -- reset ----------------------------------------------------------------------------------
    def reset(self, seed: int, options: Mapping[str, Any] | None = None
              ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """A fresh world with ``seed``, the machine at the goal's start; returns (observation, info).

        Args:
            seed: the episode seed (the world's soil, sensor noise, scanner drift, the drawn start).
            options: the goal's reset options (the trench's start; the region takes none).

        Raises:
            EnvError: a bad seed or option, or a start pose the machine cannot reach.
        """
        if self._closed:
            raise EnvError("the environment is closed")
        seed = check_seed(seed)
        start = self.goal.start(seed, options)
        r = self.resolved
        self.sim = sim = make_world(self.machine.name, r.robot, r.scene, seed=seed)
        self.control_dt = sim.control_dt
        self._attach(sim)
        info = self.goal.reset(sim, seed, start)
        self.over = False
        self.steps = 0
        self.reading = self.read()
        obs = self.observation(self.reading)
        self.goal.started()
        return obs, info

    def _attach(self, sim) -> None:
        """The fresh world's actuators, rate ranges, held angles, pumps and force sensor."""
        m, model = self.machine, sim.model
        act = _actuators(model, m)
        ctrl = model.actuator_ctrlrange[act]
        self._lo, self._hi = ctrl[self.driven, 0].copy(), ctrl[self.driven, 1].copy()
        self._held_limit = ctrl[self.held, 1].copy()
        home = np.asarray(m.home, dtype=float) if m.home is not None else keyframe_qpos(model, "home", m.joints)
        self._hold = home[self.held].copy()
        self._held_qpos = model.jnt_qposadr[[element_id(model, "joint", m.joints[k]) for k in self.held]]
        self._gain = float(sim.robot.setpoint_gain_per_s) if len(self.held) else 0.0
        self._flows = sim.drive.flows if m.hydraulics is not None else None
        self._rates = np.zeros(len(m.joints))
        self._dof = model.jnt_dofadr[[element_id(model, "joint", j) for j in m.joints]]
        if m.force_reading == "ft":
            self.ft = ForceSensor.from_config(model, self.resolved.sensing.force_sensor, joints=m.joints)
            self._ft_out = np.zeros((4, 3))

    # -- step -----------------------------------------------------------------------------------
    def step(self, action: Any) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        """One control step with the driven joints' rates ``action`` (4,) in [-1, 1] of their ranges.

        Raises:
            EnvError: the action is outside [-1, 1], not finite or of the wrong shape, or no episode runs.
        """
        rates = self.rates(action)
        try:
            self.sim.step_rates(rates)
            reading = self.read()
        except (Diverged, OutOfTime) as exc:
            return self.diverged(exc)
        return self.after_step(reading)

    def rates(self, action: Any) -> np.ndarray:
        """Every actuator's set-point rate for ``action`` (the first half of :meth:`step`)."""
        if self.over:
            raise EnvError("the episode has ended (or never started): call reset() first")
        return self.checked_rates(check_vector(action, self.action_low, self.action_high,
                                               "the joint action (rates in [-1, 1])"))

    def checked_rates(self, a: np.ndarray) -> np.ndarray:
        """:meth:`rates` of an action (4,) float64 already checked (the batched environment checks all at
        once): the driven actuators' rates (shared between the pumps on a machine with hydraulics) and the
        held joints' servo law, in the machine's joint order [rad/s, m/s]."""
        a = np.clip(a, -1.0, 1.0)
        v = np.where(a >= 0, a * self._hi, -a * self._lo)
        if self._flows is not None:
            v = v * share_pump_flow(self._flows(v), PUMPS, self.machine.hydraulics.pump_flow_m3_s)
        rates = self._rates
        rates[self.driven] = v
        if len(self.held):
            rates[self.held] = setpoint_rates(self._hold, self.sim.data.qpos[self._held_qpos], gain_per_s=self._gain,
                                              rate_limit=self._held_limit)
        return rates

    def diverged(self, exc: BaseException):
        """The step's result when the world diverged (or ran out of wall-clock time): terminated, reward 0."""
        self.over = True
        self.reading = self.read()
        return (self.observation(self.reading), 0.0, True, False,
                {"time_s": self.goal.elapsed(), "diverged": str(exc)})

    def after_step(self, reading) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        """The step's observation, reward, ends and info once the world has stepped (the second half of :meth:`step`)."""
        step = self.account(reading)
        return self.finish(step, self.observation(reading))

    def account(self, reading, measured: tuple[float, float] | None = None) -> dict[str, Any]:
        """The goal's bookkeeping of a step the world has taken (the reward's terms, the ends, the info);
        :meth:`finish` completes it once the observation is read. ``measured``: the goal's true measures
        when already taken (the batched environment measures all copies' trenches at once)."""
        self.steps += 1
        step = self.goal.account(reading, measured)
        self.over = step["terminated"] or step["truncated"]
        return step

    def finish(self, step: dict[str, Any], observation: dict[str, np.ndarray]
               ) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        """The step's result from :meth:`account`'s ``step`` and the observation: the goal's last terms
        (the trench's shaping, from the observed tip) and the reward, their sum."""
        terms = step["terms"]
        self.goal.finish(terms)
        return observation, float(sum(terms.values())), step["terminated"], step["truncated"], step["info"]

    # -- observation ----------------------------------------------------------------------------
    def read(self):
        """The world's reading now: its full sensor reading (:meth:`observe`: the F/T, the joints' torques)
        where the machine's force reading or the goal needs it, else its :class:`Encoders`."""
        sim = self.sim
        if self._observes:
            return sim.observe()
        return Encoders(sim.joint_angles(), sim.data.qvel[self._dof].copy())

    def observation(self, reading) -> dict[str, np.ndarray]:
        """The observation of the world's ``reading`` (:meth:`read`)."""
        m = self.machine
        obs = {"q": np.clip(reading.q, -m.angle_bound_rad, m.angle_bound_rad).astype(np.float32),
               "qdot": np.clip(reading.qdot, -m.speed_bound_rad_s, m.speed_bound_rad_s).astype(np.float32)}
        if m.force_reading == "cylinders":
            obs["cylinder_force"] = np.clip(self.sim.cylinder_forces(), self.force_low, self.force_high
                                            ).astype(np.float32)
        else:
            obs["ft"] = self.wrench(reading).astype(np.float32)
        obs.update(self.goal.observe(reading))
        return obs

    def wrench(self, reading) -> np.ndarray:
        """The wrist F/T reading about the tip (6,) [N, N m] (zeros when the reading is not finite)."""
        try:
            ft = self.ft.reading_into(reading, self._ft_out)
            return np.concatenate([ft[0], ft[1]])
        except ExcavsimError:  # a non-finite reading (a diverged world): report zeros
            return np.zeros(6)

    def close(self) -> None:
        """Free the world; a closed core cannot be reset (closing twice is fine)."""
        self.sim = None
        self.over = True
        self._closed = True


def _actuators(model: mujoco.MjModel, machine: Machine) -> np.ndarray:
    """The actuator of each of ``machine``'s joints, in its joint order: named as the joint without
    ``_joint`` (the models' convention: the T3's ``waist``, an excavator's ``swing``)."""
    return np.array([element_id(model, "actuator", j.removesuffix("_joint")) for j in machine.joints])


def _with_fields(spec: EpisodeSpec, kind, given: dict[str, Any]) -> EpisodeSpec:
    """``spec`` with the keywords ``given`` (not None) over its fields, and the goal's defaults for those
    of :data:`SPEC_KEYWORDS` that neither sets."""
    update = {k: v for k, v in kind.SPEC_DEFAULTS.items() if getattr(spec, k) is None}
    update.update({k: v for k, v in given.items() if v is not None})
    if not update:
        return spec
    if "seed" in update:
        update["seed"] = check_seed(update["seed"])
    return parse_config({**spec.model_dump(exclude_unset=True), **update}, EpisodeSpec,
                        source="the environment's spec")
