"""The hydraulic excavators' actuation and their world: cylinders driven within relief pressure and pump flow.

The excavator models (``models/tb035``, ``models/excavator_25t``, written by ``scripts/make_excavators.py``)
drive each joint through its cylinder: a spatial tendon between the cylinder's pins whose actuator is an
integrating servo on the cylinder's length, its force clipped at the relief pressure times the piston or
annulus area and its set-point rate at the pump's flow over that area (the MJCF's ``forcerange`` and
``ctrlrange``; the T3's ``intvelocity`` servos do the same per joint, :mod:`excavsim.robot.servo`).

:class:`HydraulicDrive` is the valve law on top, the excavator's counterpart of
:func:`~excavsim.robot.servo.setpoint_rates`: joint targets become cylinder length targets through the
closed-form kinematics (:mod:`excavsim.robot.cylinders`), the set-points' speeds are proportional to
their distance from those targets (the set-point, not the measured length: a stalled cylinder's set-point
stops at the target instead of winding up, and the servo pushes at relief until the load gives way) and
clipped at each cylinder's own flow limit, and then the two pumps' flow is shared
(Rowe 1997 §4.0: when functions on one pump move together neither reaches its own peak speed; which
functions share a pump Rowe does not say: boom with bucket and stick with swing is assumed;
:func:`~excavsim.robot.cylinders.share_pump_flow`).

A simplified hydraulic model, stated: the oil is incompressible (no cylinder stiffness from the oil
column), the valve is an ideal proportional flow source with no spool dynamics, deadband or
deceleration planning (a full-speed swing of the 25 t machine overshoots), relief is a hard force clip
and the pumps deliver their rated flow at any pressure (no power limit).

:class:`ExcavatorWorld` steps such a model with the world's soil (:class:`~excavsim.world.soil.SoilModel`)
at a fixed control rate, as the loading world does for the loading
machines: the soil model reads the bucket, cuts and fills, and its wrench on the bucket is applied through
``xfrc_applied``; the cylinder force sensors and the F/T at the bucket pin read the result.

To the trenching loop an :class:`ExcavatorWorld` is what :class:`~excavsim.world.simulation.Simulation` is
for the T3: a :class:`~excavsim.world.facade.World` (``step_hooks``, ``time``, ``settle_soil``, ``volumes``,
the watchdog's ``Diverged`` and the episode's ``OutOfTime``) and the executor's
:class:`~excavsim.handoff.observation.Servos`: :meth:`ExcavatorWorld.track` steps towards joint targets
through :class:`HydraulicDrive`, :meth:`ExcavatorWorld.observe` reads the encoders, the joint torques the
cylinders apply (cylinder force x moment arm) and the F/T at the bucket pin with Gaussian noise
(``truth.ft_force_noise_n``, ``ft_torque_noise_nm``; the T3 testbed's digging vibration,
``ft_dig_noise_share``, is the T3 arm's and is not added here), and :attr:`ExcavatorWorld.torque_limit`
is each joint's relief torque at the present pose in the direction it pushes now (relief pressure x
piston or annulus area x moment arm), so ``actuator_force / torque_limit`` is the share of the relief
pressure a cylinder works at.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import mujoco
import numpy as np

from excavsim import constants
from excavsim.config import SceneConfig, SoilParams, get_soil, load_scene_config
from excavsim.errors import ExcavsimError
from excavsim.handoff.observation import Diverged, Observation, OutOfTime
from excavsim.readouts import element_id
from excavsim.robot.cylinders import share_pump_flow
from excavsim.robot.excavators import CHAIN_JOINTS, FUNCTIONS, PUMPS, ExcavatorSpec, get_machine
from excavsim.world.simulation import Truth
from excavsim.world.soil import SoilModel

# The excavators' joints in the spec's order; the actuators carry the function's name.
EXCAVATOR_JOINTS = CHAIN_JOINTS
LINKAGE_JOINTS = ("rocker_joint", "link_joint")  # the bucket's four-bar, closed by an equality constraint
CYLINDER_FORCE_SENSORS = ("swing_torque", "boom_cylinder_force", "stick_cylinder_force", "bucket_cylinder_force")
CONTROL_RATE_HZ = 50.0  # the excavators' control rate [Hz] (assumed, as the loading machines')


class HydraulicDrive:
    """Joint targets to the four servos' set-point rates, within each cylinder's and each pump's flow.

    Args:
        spec: the machine's numbers.
        model: its compiled MuJoCo model (the actuators' flow limits are read from ``ctrlrange``).
        gain_per_s: proportional gain from length (angle) error to set-point rate [1/s].
    """

    def __init__(self, spec: ExcavatorSpec, model: mujoco.MjModel, gain_per_s: float = 4.0):
        self.spec = spec
        self.gain = float(gain_per_s)
        self.act = np.array([element_id(model, "actuator", f) for f in FUNCTIONS])
        self.ctrl_lo = model.actuator_ctrlrange[self.act, 0].copy()
        self.ctrl_hi = model.actuator_ctrlrange[self.act, 1].copy()
        self.actadr = model.actuator_actadr[self.act].copy()
        self.reference = self.lengths(np.asarray(spec.ref))
        m = spec.swing_motor
        self._swing_m3_per_rad = m.displacement_m3 * m.ratio / (2.0 * np.pi)

    def lengths(self, q: np.ndarray) -> np.ndarray:
        """(4,) the swing angle and the three cylinders' lengths at joint angles ``q`` (4,) [rad, m]."""
        s = self.spec
        return np.array([q[0]] + [float(s.cylinder_length(f, q[j])) for j, f in enumerate(FUNCTIONS) if j > 0])

    def flows(self, rates: np.ndarray) -> np.ndarray:
        """(4,) the oil flow [m^3/s] each function takes at set-point rates ``rates`` [rad/s, m/s]."""
        s = self.spec
        out = [abs(rates[0]) * self._swing_m3_per_rad]
        out += [float(s.cylinder(f).flow(rates[j])) for j, f in enumerate(FUNCTIONS) if j > 0]
        return np.array(out)

    def setpoints(self, data: mujoco.MjData) -> np.ndarray:
        """(4,) the servos' set-points now: swing angle and cylinder lengths [rad, m] (activation + reference)."""
        return data.act[self.actadr] + self.reference

    def rates(self, target: np.ndarray, setpoints: np.ndarray) -> np.ndarray:
        """(4,) the controls (set-point rates) that move the servos' ``setpoints`` (4,) [rad, m] towards the
        lengths of joint angles ``target`` (4,) [rad].

        Raises:
            ExcavsimError: ``target`` is not 4 finite angles within the joint limits.
        """
        t = np.asarray(target, dtype=float)
        a = self.spec.arm
        if t.shape != (4,) or not np.all(np.isfinite(t)) or not a.within_limits(t):
            raise ExcavsimError(f"target must be 4 finite joint angles (swing, boom, stick, bucket) within "
                                f"{np.round(a.lower, 4).tolist()} .. {np.round(a.upper, 4).tolist()} rad; "
                                f"given {target!r}")
        v = np.clip(self.gain * (self.lengths(t) - np.asarray(setpoints, dtype=float)), self.ctrl_lo, self.ctrl_hi)
        return v * share_pump_flow(self.flows(v), PUMPS, self.spec.pump_flow_m3_s)


class ExcavatorWorld:
    """An excavator model and the world's soil in its pit, stepped at :data:`CONTROL_RATE_HZ`.

    Args:
        machine: ``tb035`` or ``excavator_25t`` (an :class:`~excavsim.robot.excavators.ExcavatorSpec` name).
        soil: soil parameters or a preset name of ``configs/soils.yaml`` (default the scene's).
        scene: settlement, truth terms and bucket handling (``configs/scene.yaml`` when None); the initial
            fill is the pit's depth (the soil flush with the ground).
        seed: the episode seed (the soil's heterogeneity).
        keyframe: the pose to start from.
    """

    def __init__(self, machine: str, soil: SoilParams | str | None = None, scene: SceneConfig | None = None, *,
                 seed: int = 0, keyframe: str = "home"):
        self.spec = get_machine(machine)
        self.model = self._compile()
        self.data = mujoco.MjData(self.model)
        mujoco.mj_resetDataKeyframe(self.model, self.data, element_id(self.model, "key", keyframe))
        mujoco.mj_forward(self.model, self.data)
        box = element_id(self.model, "body", constants.SOIL_BOX_BODY)
        depth = -float(self.model.body_pos[box][2])
        base = scene or load_scene_config()
        self.scene = base.model_copy(update={"initial_soil_height_m": depth})
        if soil is None or isinstance(soil, str):
            soil = get_soil(soil or self.scene.soil)
        self.soil = SoilModel(self.model, self.scene, soil, np.random.default_rng(seed))
        self.drive = HydraulicDrive(self.spec, self.model)
        jids = [element_id(self.model, "joint", j) for j in EXCAVATOR_JOINTS]
        self._qpos = np.array([self.model.jnt_qposadr[j] for j in jids])
        self._rest_qpos = np.array([self.model.jnt_qposadr[element_id(self.model, "joint", j)]
                                    for j in (*EXCAVATOR_JOINTS, *LINKAGE_JOINTS)])
        self._sensors = np.array([self.model.sensor_adr[element_id(self.model, "sensor", s)]
                                  for s in CYLINDER_FORCE_SENSORS])
        self._bucket = element_id(self.model, "body", constants.BUCKET_BODY)
        self.substeps = max(1, int(round(1.0 / CONTROL_RATE_HZ / self.model.opt.timestep)))
        self.control_dt = self.substeps * self.model.opt.timestep
        self.contact = None
        self.steps = 0
        self._warnings = np.array(self.data.warning.number, dtype=np.int64)
        self.seed = seed
        # the F/T's noise: a stream of its own (the soil's draws are those of the seed itself)
        self._noise_rng = np.random.default_rng((seed, 11))
        ft = (element_id(self.model, "sensor", constants.FT_FORCE_SENSOR),
              element_id(self.model, "sensor", constants.FT_TORQUE_SENSOR))
        fa, ta = (int(self.model.sensor_adr[i]) for i in ft)
        self._ft_idx = np.r_[fa:fa + 3, ta:ta + 3]
        self._ft_sigma = np.repeat([self.scene.truth.ft_force_noise_n, self.scene.truth.ft_torque_noise_nm], 3)
        self._dof = np.array([self.model.jnt_dofadr[j] for j in jids])
        # Called with the world after every control step (recorders, accounts); read-only use.
        self.step_hooks: list[Callable[[ExcavatorWorld], None]] = []
        self.wall_deadline: float | None = None  # time.perf_counter() after which a step raises OutOfTime
        self.diverged: str | None = None
        self._clock = float(self.data.time)

    def _compile(self) -> mujoco.MjModel:
        """The world's MuJoCo model: the machine's scene (a world with more in it adds its bodies here)."""
        return mujoco.MjModel.from_xml_path(str(self.spec.scene_xml))

    def joint_angles(self) -> np.ndarray:
        """The joint encoders (4,): swing, boom, stick, bucket [rad]."""
        return self.data.qpos[self._qpos].copy()

    def cylinder_forces(self) -> np.ndarray:
        """(4,) the swing torque [N m] and the boom, stick and bucket cylinder forces [N] (positive pushes)."""
        return self.data.sensordata[self._sensors].copy()

    @property
    def time(self) -> float:
        """Simulated time of the last good control step [s]."""
        return self._clock

    def joint_torques(self) -> np.ndarray:
        """(4,) the torque each function applies to its joint [N m]: the swing motor's, and each cylinder's
        force times its moment arm ``dL/dq`` at the present angle (the closed forms of
        :mod:`excavsim.robot.cylinders`)."""
        f = self.cylinder_forces()
        q = self.joint_angles()
        return np.array([f[0]] + [f[j] * float(self.spec.moment_arm(fn, q[j]))
                                  for j, fn in enumerate(FUNCTIONS) if j > 0])

    @property
    def torque_limit(self) -> np.ndarray:
        """(4,) each joint's relief torque at the present pose in the direction its function pushes now
        [N m] (relief pressure x piston or annulus area x moment arm; the swing motor's relief torque)."""
        lim = self.spec.joint_torque_limits(self.joint_angles())
        return np.where(self.joint_torques() >= 0.0, lim[:, 1], -lim[:, 0])

    def observe(self) -> Observation:
        """The sensor-level observation now: encoders, joint velocities, the functions' joint torques and
        the F/T at the bucket pin with its noise (see the module docstring)."""
        d = self.data
        ft = d.sensordata[self._ft_idx] + self._noise_rng.standard_normal(6) * self._ft_sigma
        return Observation(self._clock, self.joint_angles(), d.qvel[self._dof].copy(), self.joint_torques(),
                           ft[:3], ft[3:])

    def track(self, target: np.ndarray) -> Observation:
        """One control step towards joint angles ``target`` (4,) [rad] through the hydraulic drive; the observation."""
        self.step(target)
        return self.observe()

    def place(self, q: np.ndarray, setpoints: np.ndarray | None = None) -> None:
        """Set the machine still at joint angles ``q`` (4,) (swing, boom, stick, bucket) [rad], the bucket
        linkage closed, velocities and valves zero, and the servos' set-points at the swing angle and the
        cylinders' lengths of the angles ``setpoints`` (4,) (default ``q``) [rad]
        (:meth:`~excavsim.robot.excavators.ExcavatorSpec.rest_state`, as the keyframes are written); the derived
        quantities recomputed (``mj_forward``): a start pose without a simulated move. With the set-points at
        ``q`` the cylinders then droop under the arm's weight, as from a keyframe; set-points above ``q`` by
        that droop hold the arm where it is (:meth:`DroopCompensation.place
        <excavsim.execution.droop.DroopCompensation.place>`)."""
        qpos, _ = self.spec.rest_state(q)
        _, act = self.spec.rest_state(q if setpoints is None else setpoints)
        d = self.data
        d.qpos[self._rest_qpos] = qpos
        d.qvel[:] = 0.0
        d.act[self.drive.actadr] = act
        d.ctrl[self.drive.act] = 0.0
        mujoco.mj_forward(self.model, d)

    def settle_soil(self) -> None:
        """Settle the whole terrain now (after a dig or a dump)."""
        self.soil.settle_all()

    def volumes(self):
        """Privileged truth: soil in the pit, in the bucket and in spoil [m^3]."""
        return self.soil.volumes()

    @property
    def truth(self):
        """Privileged world state (true terrain, soil volumes, the last soil contact), as the T3's world gives."""
        return Truth(self.soil.grid.heights.copy(), self.soil.volumes(), self.contact)

    def step(self, target: np.ndarray) -> np.ndarray:
        """One control step towards joint angles ``target`` (4,) [rad]; the joint encoders after it.

        Raises:
            ExcavsimError: ``target`` is not 4 finite angles within the limits.
            Diverged: MuJoCo warned, or the state is not finite (now or in an earlier step).
            OutOfTime: the step came after :attr:`wall_deadline`.
        """
        return self.step_rates(self.drive.rates(target, self.drive.setpoints(self.data)))

    def step_rates(self, rates: np.ndarray) -> np.ndarray:
        """One control step with the four servos' set-point rates ``rates`` (4,) [rad/s, m/s] given directly
        (a valve command, as a joint-level agent gives it; :meth:`step` computes them from joint targets); the
        caller keeps them within the flow limits (``drive.ctrl_lo``/``ctrl_hi``; MuJoCo clamps to ``ctrlrange``).
        The joint encoders after it.

        Raises:
            Diverged: MuJoCo warned, or the state is not finite (now or in an earlier step).
            OutOfTime: the step came after :attr:`wall_deadline`.
        """
        d = self.data
        if self.diverged is not None:
            raise Diverged(f"the excavator world diverged earlier and cannot go on: {self.diverged}")
        if self.wall_deadline is not None and time.perf_counter() > self.wall_deadline:
            raise OutOfTime(f"the episode's wall-clock limit passed at t = {self._clock:.2f} s simulated")
        d.ctrl[self.drive.act] = rates
        self.contact = self.soil.step(d, self.control_dt)
        d.xfrc_applied[self._bucket] = self.contact.wrench
        mujoco.mj_step(self.model, d, self.substeps)
        self.steps += 1
        counts = np.array(d.warning.number, dtype=np.int64)
        if (counts > self._warnings).any() or not np.all(np.isfinite(d.qpos)):
            self._warnings = counts
            self.diverged = f"step {self.steps} (t = {d.time:.2f} s)"
            raise Diverged(f"the excavator world diverged at step {self.steps} (t = {d.time:.2f} s)")
        self._clock = float(d.time)
        for hook in self.step_hooks:
            hook(self)
        return self.joint_angles()
