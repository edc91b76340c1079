"""The world facade: MuJoCo and the soil stepped together at a fixed control rate.

The rest of the package talks to the world only through :class:`Simulation`: it sets servo commands
and reads :class:`~excavsim.handoff.observation.Observation` (joint angles and velocities, actuator
forces, the noisy wrist F/T reading, time), the sensor-level data a real T3 gives; to the executor
it is a :class:`~excavsim.handoff.observation.Servos`. The true terrain, the soil volumes and the
soil's wrench on the bucket are available separately through :attr:`Simulation.truth`, as privileged
data for tests, metrics and logging: the robot's mind never reads them.

One control step (:meth:`Simulation.step`): the soil model reads the bucket's pose and velocity,
cuts and moves soil and computes its wrench on the bucket; the wrench is written to
``xfrc_applied`` of the bucket body and held over the physics substeps; MuJoCo steps; the
observation is read. The F/T sensor (``ft_force``/``ft_torque`` at ``ft_mount``) therefore measures
the soil force plus the bucket's own weight and inertia, as a real wrist sensor does. Its reading
(:meth:`Simulation.observe`) adds Gaussian noise (``truth.ft_force_noise_n``, ``ft_torque_noise_nm``)
and, while the cutting edge advances into soil, the arm's vibration that the testbed's sensor read
while digging (``truth.ft_dig_noise_share``, calibrated to the thesis' Table 4; see
:meth:`Simulation._dig_disturbance`), drawn from a random stream of its own.

With ``truth.arm_damping_ratio`` and ``truth.arm_give_share`` (off by default) the planar servos ring
on contact and after a move and the joints give under load beyond what their encoders read, as the
testbed's hydraulic arm did (Singh 1995 §7.1.3, Fig. 104; :mod:`excavsim.world.arm`).

A watchdog checks every control step. MuJoCo meets an unstable state (a "huge value in QACC") by
warning and silently resetting the state to the model's default, with its time back at 0, so a
state that is finite again and a clock that restarts would hide the failure and let every timeout
wait forever. A step therefore raises :class:`~excavsim.handoff.observation.Diverged` when any of
MuJoCo's warning counters (``data.warning``) grew, when MuJoCo's time did not advance by exactly one
control period (a reset), or when the joint state is not finite; every later step raises it again.
:attr:`Simulation.time` is the simulated time of the last good step, so it never goes back. A step
after :attr:`Simulation.wall_deadline` (a ``time.perf_counter()`` value, set by the episode loop)
raises :class:`~excavsim.handoff.observation.OutOfTime`.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable

import mujoco
import numpy as np
from dm_control import mjcf

from excavsim.config import RobotConfig, SceneConfig, SoilParams, get_soil, load_robot_config, load_scene_config
from excavsim.errors import ConfigError, Diverged, OutOfTime
from excavsim.handoff.observation import Observation
from excavsim.readouts import ModelIndex
from excavsim.robot.servo import setpoint_rates
from excavsim.world.arm import apply_arm_truth, encoder_angles
from excavsim.world.scene import build_physics
from excavsim.world.soil import SoilContact, SoilModel, Volumes

# MuJoCo's warnings (mjtWarning), in the order of data.warning
WARNING_NAMES = tuple(mujoco.mjtWarning(i).name for i in range(int(mujoco.mjtWarning.mjNWARNING)))


@dataclasses.dataclass(frozen=True)
class Truth:
    """Privileged world state for tests and logging: never an input to the robot's mind."""

    heights: np.ndarray
    volumes: Volumes
    contact: SoilContact | None


# The F/T's digging disturbance acts while the edge advances into soil faster than this: the bucket digs
# (penetrates along its approach, drags, curls). The touch-down's vertical descent drifts horizontally
# by less, so that it meets the soil as the quiet sensor does (as on the testbed, whose touch-down read
# the sensor at rest, §7.1.3).
DIG_ADVANCE_M_S = 0.01


class Simulation:
    """MuJoCo physics of the testbed plus the soil, stepped at the robot's control rate.

    Args:
        robot: servo configuration (``configs/robot.yaml`` when None).
        scene: scene and soil configuration (``configs/scene.yaml`` when None).
        soil: soil parameters or preset name (the scene's ``soil`` preset when None).
        seed: the episode seed; the soil's heterogeneity, rocks and the sensor noise derive from it,
            so the same seed gives the same episode bit for bit.
    """

    def __init__(self, robot: RobotConfig | None = None, scene: SceneConfig | None = None,
                 soil: SoilParams | str | None = None, *, seed: int = 0):
        self.robot = robot or load_robot_config()
        self.scene = scene or load_scene_config()
        if soil is None or isinstance(soil, str):
            soil = get_soil(soil or self.scene.soil)
        self.seed = seed
        self.physics: mjcf.Physics = build_physics(self.robot, self.scene)
        self.model: mujoco.MjModel = self.physics.model.ptr
        self.data: mujoco.MjData = self.physics.data.ptr
        # the first two children are those of spawn(2): adding the third changed no earlier draw
        world_rng, self._noise_rng, self._dig_rng = np.random.default_rng(seed).spawn(3)
        self.soil = SoilModel(self.model, self.scene, soil, world_rng)
        self.control_dt = 1.0 / self.robot.control_rate_hz
        self.substeps = max(1, int(round(self.control_dt / self.model.opt.timestep)))
        self.control_dt = self.substeps * self.model.opt.timestep
        self.index = ModelIndex.from_model(self.model)
        self._joint_qpos = self.index.qpos
        self._joint_dof = self.index.dof
        self._act = self.index.actuator
        self._bucket = self.index.bucket_body
        self._ft_adr = (self.index.ft_force, self.index.ft_torque)
        fa, ta = self._ft_adr
        self._ft_idx = np.r_[fa:fa + 3, ta:ta + 3]
        self._ft_sigma = np.repeat([self.scene.truth.ft_force_noise_n, self.scene.truth.ft_torque_noise_nm], 3)
        self._ft_dig = self.scene.truth.ft_dig_noise_share
        truth = self.scene.truth
        # the arm's compliance (excavsim.world.arm): off by default, when the model is left as built
        self.arm_truth = None
        if truth.arm_damping_ratio is not None or truth.arm_give_share > 0.0:
            self.arm_truth = apply_arm_truth(self.model, self.data, self._act, self._joint_dof,
                                             damping_ratio=truth.arm_damping_ratio, give_share=truth.arm_give_share)
        self._give = self.arm_truth.give if self.arm_truth is not None and self.arm_truth.gives else None
        self.rate_limit = self.model.actuator_ctrlrange[self._act, 1].copy()
        self.torque_limit = self.model.actuator_forcerange[self._act, 1].copy()
        self.contact: SoilContact | None = None
        self.soil_enabled = True
        # Called with the Simulation after every control step (recorders, live plots); read-only use.
        self.step_hooks: list[Callable[[Simulation], None]] = []
        self.steps = 0  # control steps taken
        self.wall_deadline: float | None = None  # time.perf_counter() after which a step raises OutOfTime
        self.diverged: str | None = None  # why the physics diverged (every later step raises Diverged)
        self._clock = float(self.data.time)  # simulated time of the last good step [s]
        self._warnings = self._warning_counts()
        # views into MjData (they live as long as ``data``): read every step without re-wrapping
        self._warning_view = self.data.warning.number
        self._qpos_view, self._qvel_view = self.data.qpos, self.data.qvel
        self._sensor_view, self._actuator_force_view = self.data.sensordata, self.data.actuator_force
        self._xfrc_bucket = self.data.xfrc_applied[self._bucket]  # the bucket's row (6,): force, torque

    # -- sensing --------------------------------------------------------------------------------
    @property
    def time(self) -> float:
        """Simulated time of the last good control step [s]: never goes back, also after a divergence."""
        return self._clock

    def joint_angles(self) -> np.ndarray:
        """The joint encoders (6,) [rad], in ``constants.JOINTS`` order; draws no sensor noise. With
        ``truth.arm_give_share`` they miss the transmission's give (:func:`~excavsim.world.arm.encoder_angles`);
        the links' true angles are ``data.qpos``."""
        q = self.data.qpos[self._joint_qpos].copy()
        return q if self._give is None else encoder_angles(q, self._actuator_force_view[self._act], self._give)

    def observe(self) -> Observation:
        """The sensor-level observation now (F/T with noise)."""
        # one draw of the six noises: the same numbers as a draw of the three forces, then the torques
        # (standard normals times sigma: the numbers rng.normal(0, sigma) gives, at a quarter of its cost)
        ft = self._sensor_view[self._ft_idx] + self._noise_rng.standard_normal(6) * self._ft_sigma
        c = self.contact
        if self._ft_dig > 0.0 and c is not None and c.depth_m > 0.0 and c.advance_speed_m_s > DIG_ADVANCE_M_S:
            ft += self._dig_disturbance(c)
        # the MjData views cached at construction: the same arrays, without re-wrapping them every step
        q = self._qpos_view[self._joint_qpos]
        if self._give is not None:
            q = encoder_angles(q, self._actuator_force_view[self._act], self._give)
        return Observation(self._clock, q, self._qvel_view[self._joint_dof],
                           self._actuator_force_view[self._act], ft[:3], ft[3:])

    def _dig_disturbance(self, contact: SoilContact) -> np.ndarray:
        """The F/T reading's error from the arm's vibration while the bucket digs (6,): force, torque.

        Calibration target: the testbed's force signal scatters from sample to sample far more than
        the simulated one (Table 4: shuffled 10-fold 3-NN errs by 72 N on the real sand, 11 N here
        without this term), and the soil's strength factor cannot give that scatter: the dig force
        here is mostly the load's weight (about 180 of 250 N), which every method predicts from the
        swept volume, and a fine-scale strength factor on the cutting force of log-std 0.5 raised
        3-NN's error only to 31 N. The testbed's hydraulic arm oscillated (§7.1.3, Fig. 104: "force
        readings must be taken after this oscillation has died down") and its joints complied under
        great resistive forces (§7.1.3); the JR3 between wrist and bucket reads the bucket's inertial
        force ``m a`` with the soil's. The simulated servos neither vibrate nor comply, so the reading
        gets it here: a random force at the bucket's centre of mass, independent per control step, of
        standard deviation per axis ``truth.ft_dig_noise_share`` times the magnitude of the soil's
        force on the bucket (load included: the force the arm's joints resist), in the sensor's frame
        with its moment about the sensor, while the cutting edge advances into soil faster than
        ``DIG_ADVANCE_M_S`` (the touch-down's vertical descent and readings at rest do not have it).
        Simplifications (assumed): white from step to step (the testbed's 8-10 Hz samples see
        independent values), proportional to the force, and the arm's motion does not carry it.
        """
        d = self.data
        b = self._bucket
        n = self._dig_rng.standard_normal(3) * (self._ft_dig * float(np.linalg.norm(contact.force)))
        site = self.index.ft_site
        rot = d.site_xmat[site].reshape(3, 3)  # columns: the sensor's axes in the world
        a = d.xipos[b] - d.site_xpos[site]
        # arm x n written out: np.cross's own products and differences (the same numbers) without its fixed cost
        moment = np.array([a[1] * n[2] - a[2] * n[1], a[2] * n[0] - a[0] * n[2], a[0] * n[1] - a[1] * n[0]])
        return np.concatenate([rot.T @ n, rot.T @ moment])

    @property
    def truth(self) -> Truth:
        """Privileged world state (true terrain, soil volumes, the last soil contact)."""
        return Truth(self.soil.grid.heights.copy(), self.soil.volumes(), self.contact)

    # -- stepping -------------------------------------------------------------------------------
    def step(self, ctrl: np.ndarray | None = None) -> Observation:
        """One control step (:meth:`step_rates`) and the observation after it (:meth:`observe`).

        Args:
            ctrl: (6,) set-point rates for the servos [rad/s]; the previous controls when None.

        Raises:
            ExcavsimError: ``ctrl`` is not a finite (6,) vector.
            Diverged: the physics became unstable in this step or an earlier one (see the module docstring).
            OutOfTime: the step came after :attr:`wall_deadline`.
        """
        self.step_rates(ctrl)
        return self.observe()

    def step_rates(self, ctrl: np.ndarray | None = None) -> None:
        """One control step with the servos' set-point rates ``ctrl`` (6,) [rad/s] (the previous controls when
        None): soil update, then the physics substeps with the soil wrench held. The excavators' world
        steps its valves' rates by the same name (:meth:`ExcavatorWorld.step_rates
        <excavsim.world.hydraulics.ExcavatorWorld.step_rates>`), so a joint-level driver steps either.

        Raises:
            ExcavsimError: ``ctrl`` is not a finite (6,) vector.
            Diverged: the physics became unstable in this step or an earlier one (see the module docstring).
            OutOfTime: the step came after :attr:`wall_deadline`.
        """
        d = self.data
        if self.diverged is not None:
            raise Diverged(f"the simulation diverged earlier and cannot go on: {self.diverged}")
        if self.wall_deadline is not None and time.perf_counter() > self.wall_deadline:
            raise OutOfTime(f"the episode's wall-clock limit passed at t = {self._clock:.2f} s simulated")
        if ctrl is not None:
            ctrl = np.asarray(ctrl, dtype=float)
            if ctrl.shape != (len(self._act),) or not np.isfinite(ctrl).all():
                raise ConfigError(f"ctrl must be {len(self._act)} finite set-point rates [rad/s], got {ctrl!r}")
            d.ctrl[self._act] = ctrl
        if self.soil_enabled:
            self.contact = self.soil.step(d, self.control_dt)
            self._xfrc_bucket[:] = self.contact.wrench
        else:
            self._xfrc_bucket[:] = 0.0
        before = float(d.time)
        mujoco.mj_step(self.model, d, self.substeps)
        self.steps += 1
        why = self._watchdog(before)
        if why is not None:
            self.diverged = f"{why} in the control step from t = {self._clock:.3f} s (step {self.steps})"
            raise Diverged(f"the simulation diverged: {self.diverged}")
        self._clock = float(d.time)
        for hook in self.step_hooks:
            hook(self)

    def place(self, q: np.ndarray, setpoints: np.ndarray | None = None) -> None:
        """Set the joints at angles ``q`` (6,) [rad] at rest, the servos' integrator states (their position
        set-points) at ``setpoints`` (default the same angles: the integrating servos hold them without
        droop) and their rates zero, and recompute the derived quantities (``mj_forward``): a start pose
        without a simulated move."""
        d = self.data
        d.qpos[self._joint_qpos] = q
        d.qvel[:] = 0.0
        d.act[self.model.actuator_actadr[self._act]] = q if setpoints is None else setpoints
        d.ctrl[self._act] = 0.0
        mujoco.mj_forward(self.model, d)

    def _warning_counts(self) -> np.ndarray:
        """How often MuJoCo has raised each of its warnings (data.warning[i].number), in WARNING_NAMES order."""
        return np.array(self.data.warning.number, dtype=np.int64)  # one vectorized read (a loop costs 90 us)

    def _watchdog(self, time_before: float) -> str | None:
        """Why the step just taken from MuJoCo time ``time_before`` [s] diverged, or None if it did not."""
        d = self.data
        counts = self._warning_view
        if (counts > self._warnings).any():
            grew = np.flatnonzero(counts > self._warnings)
            self._warnings = np.array(counts, dtype=np.int64)
            names = ", ".join(f"{WARNING_NAMES[i]} (at index {d.warning[i].lastinfo})" for i in grew)
            return f"MuJoCo warned {names}" + (" and reset the state" if d.time < time_before + 0.5 * self.control_dt
                                               else "")
        if abs(d.time - time_before - self.control_dt) > 0.5 * self.model.opt.timestep:
            return f"MuJoCo's time went from {time_before:.3f} s to {d.time:.3f} s (the state was reset)"
        if not (math.isfinite(float(self._qpos_view.sum())) and math.isfinite(float(self._qvel_view.sum()))):
            # a NaN or an infinity anywhere makes the sum non-finite
            return "the joint state is not finite"
        return None

    def track(self, target: np.ndarray) -> Observation:
        """One control step driving the joints towards ``target`` (6,) [rad] with the servo law."""
        q = self.data.qpos[self._joint_qpos] if self._give is None else self.joint_angles()  # the encoders
        rates = setpoint_rates(target, q, gain_per_s=self.robot.setpoint_gain_per_s, rate_limit=self.rate_limit)
        return self.step(rates)

    def settle_soil(self) -> None:
        """Settle the whole terrain now (e.g. after a dump)."""
        self.soil.settle_all()

    def volumes(self) -> Volumes:
        """Privileged truth: soil in the box, in the bucket and in spoil (dumped outside the box) [m^3]."""
        return self.soil.volumes()
