"""The playback on a hydraulic excavator (DiMaio 1998 §4.2, Table 4.1; the experiment of ch. 6 on the machine
the thesis modelled, the TB035, and on any excavator of :mod:`excavsim.robot.excavators`).

The world is :class:`~excavsim.world.hydraulics.ExcavatorWorld` (its cylinders within relief pressure and pump
flow, the world's soil under DiMaio's model in its pit).

**Which impedance, and why Cartesian.** DiMaio §4.2 shapes the bucket endpoint's dynamics in the arm's
vertical plane by *position-based* impedance control into eq. 4.38,
``Mm x'' = f0 + fe + (Bm s + Km)(x0 - x)`` with ``x = (r, z, alpha)``, the machine's measured values in
Table 4.1 (M 100 kg, B 5000 N s/m, K 1e4 - 1e5 N/m). So the impedance here is Cartesian at the bucket tip
(radial and vertical, as the T3's), realised the same way: :class:`~excavsim.execution.playback.ImpedancePlayback`
integrates it as an admittance (App. A.2, eq. A.76) into a commanded tip, the planar inverse kinematics of
the machine's chain (read from its MJCF by :func:`~excavsim.robot.extract.arm_from_model`) gives joint
targets, and the hydraulic drive moves the cylinders to them (the position loop the real machine's
impedance controller sat on). A joint-space impedance would need the cylinders' force control, which the
model's valve law (flow-controlled cylinders) does not have, and Table 4.1's numbers are Cartesian. The bucket
angle follows the demonstration (no rotational impedance), as on the T3.

Table 4.1 gives one damping for its stiffness range: the fixed and variable laws use B = 5000 N s/m
throughout (the T3's use Table 6.5's damping factor instead). Controllers: position (K = 1e5), low (K = 1e4)
and the variable impedance of eq. 3.37 between them with the :class:`~excavsim.execution.playback.DepthDual`
depth law, the T3's chapter controller with Table 4.1's bounds. Table 4.1 is the TB035's; another excavator
plays back with the same numbers (assumed: the sources give no other machine's impedance).

**The force.** What the playback reads as fe is :class:`~excavsim.sensing.pressure.CylinderForceEstimate`:
the soil's force on the bucket from the cylinder forces (the pressure transducers) by a static balance of the
arm; the bucket pin's F/T does not see the link's load path. :class:`CylinderServos` presents the world to
the playback as the T3's servos: joint encoders and cylinder forces (with the transducers' noise,
:data:`CYLINDER_FORCE_NOISE_N`, assumed) padded to the T3's six joints.

**The demonstration** (:meth:`CylinderArm.record_demonstration`) is scripted: the tip driven by IK along a cut
in the pit (:meth:`CylinderRig.cut`: entry, down to the depth, a drag towards the machine, a curl; the TB035's
cut, scaled by the machine's reach on another excavator) in the demonstration soil, the measured tip pose and
estimated force sampled every control step; a 10 cm free descent is prepended as on the T3. Teleoperation makes one too: the keys move the tip in the arm plane and
z/c swing the cab (DiMaio §4.2's cylindrical endpoint coordinates), from 10 cm above the cut's entry.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from excavsim.apps.playback.adapter import (DEMO_SOIL, TELEOP_HEIGHT_M, Impedance, MachineAdapter, PlaybackRig,
                                            dimaio_scene)
from excavsim.config import SoilParams, get_soil
from excavsim.errors import GoalError
from excavsim.execution.demonstration import Demonstration, plane_state
from excavsim.handoff.observation import Observation
from excavsim.robot.extract import arm_from_model
from excavsim.robot.excavators import TB035
from excavsim.robot.machine import Machine, get_machine
from excavsim.sensing.pressure import CylinderForceEstimate
from excavsim.world.hydraulics import EXCAVATOR_JOINTS, ExcavatorWorld
from excavsim.world.machines import make_world

# DiMaio 1998 Table 4.1 (the excavator's column); eq. 3.37's G: the T3's chapter value (see the dated note)
TABLE_4_1 = Impedance("DiMaio 1998 Table 4.1", mass_kg=100.0, k_high_n_m=1.0e5, k_low_n_m=1.0e4, damping_n_s_m=5000.0,
                      g_n_s_m=2000.0, position="position (K=1e5)", low="low (K=1e4)")
CYLINDER_FORCE_NOISE_N = 100.0  # each cylinder force reading's noise (1 sigma) [N] (assumed: ~0.3 bar on its bore)
# The scripted demonstration cut in the arm plane at swing 0 (assumed): on the TB035, DiMaio's machine, from
# x = 3.6 m on the surface down to 0.2 m and dragged to 2.6 m (its pit runs from x = 1.2 to 5.2 m); another
# excavator cuts the same path scaled by its reach over the TB035's (their reachability tables' x_max_m)
DEMO_ENTRY_X_M, DEMO_END_X_M, DEMO_DEPTH_M = 3.6, 2.6, 0.2  # on the TB035
DEMO_PITCH, DEMO_CURL_PITCH = 0.6, -0.4  # the blade's rake while cutting and once curled [rad]
DEMO_CURL_RISE_M = 0.1  # the curl lifts the tip this much (on the TB035)
DEMO_SPEED_M_S = 0.2  # along the cut
ABOVE_M = 0.3  # a playback comes down onto the demonstration's start from this far above


class CylinderServos:
    """An :class:`~excavsim.world.hydraulics.ExcavatorWorld` as the playback's servos (the
    :class:`~excavsim.handoff.observation.Servos` protocol, the T3's six joints): ``q``/``qdot`` are
    swing, boom, stick, bucket and two zeros, ``actuator_force`` the swing torque and the three cylinder
    forces (each with the transducers' Gaussian noise) and two zeros; ``track`` takes the first four
    targets. No F/T reading: ``ft_force``/``ft_torque`` are zero (the force is read from the cylinders).

    Args:
        world: the machine and its soil.
        seed: the noise's seed.
        noise_n: the cylinder forces' noise (1 sigma) [N].
    """

    def __init__(self, world: ExcavatorWorld, seed: int = 0, noise_n: float = CYLINDER_FORCE_NOISE_N):
        self.world = world
        self.control_dt = world.control_dt
        self.rng = np.random.default_rng(seed)
        self.noise_n = float(noise_n)
        m = world.model
        lim = np.abs(m.actuator_forcerange[world.drive.act]).max(axis=1)
        self.torque_limit = np.r_[lim, 0.0, 0.0]
        self._dof = np.array([m.jnt_dofadr[m.joint(j).id] for j in EXCAVATOR_JOINTS])
        self.step_hooks: list[Callable[[ExcavatorWorld], None]] = []

    @property
    def time(self) -> float:
        return float(self.world.data.time)

    def observe(self) -> Observation:
        """The joint encoders and the cylinder forces now (the forces with the transducers' noise)."""
        w = self.world
        forces = w.cylinder_forces() + self.rng.normal(0.0, self.noise_n, 4) * np.array([0.0, 1.0, 1.0, 1.0])
        z = np.zeros(2)
        return Observation(self.time, np.r_[w.joint_angles(), z], np.r_[w.data.qvel[self._dof], z],
                           np.r_[forces, z], np.zeros(3), np.zeros(3))

    def track(self, target: np.ndarray) -> Observation:
        """One control step towards the joint targets ``target[:4]`` (swing, boom, stick, bucket) [rad], then
        each of :attr:`step_hooks` with the world (a recorder's ``stepped``). The
        drive follows a moving target ``v / gain`` behind (5 cm at 0.2 m/s): the demonstration and its
        playback both have that lag. A velocity feed-forward on the targets was tried (seed 0): unfiltered it
        differentiates the admittance's response to the force noise and made every playback worse; low-passed
        (0.1 s, 0.3 s) it cut the same soil's position error (5.4 -> 3.5-4.2 cm) but raised the stiffer soil's
        force error (6.8 -> 8.2-8.7 kN for position control, seed 0), so it is not used."""
        self.world.step(np.asarray(target, dtype=float)[:4])
        for hook in self.step_hooks:
            hook(self.world)
        return self.observe()


class CylinderRig(PlaybackRig):
    """An excavator's world, servos, planar chain and force estimate for one playback or demonstration."""

    def __init__(self, machine: Machine, soil: SoilParams, seed: int = 0):
        self.machine = machine
        self.world = make_world(machine.name, scene=dimaio_scene(), soil=soil, seed=seed)
        self.servos = CylinderServos(self.world, seed)
        self.arm = arm_from_model(self.world.model, joints=machine.chain_joints)
        self.force = CylinderForceEstimate(self.world.spec, self.arm)
        self.control_dt = self.world.control_dt
        self._observer = None

    def cut(self) -> list[np.ndarray]:
        """The scripted demonstration's waypoints (x, z, pitch) in the pit (see :data:`DEMO_ENTRY_X_M`): the entry
        on the surface, down to the depth, the drag towards the machine and the curl."""
        s = self.machine.table.x_max_m / get_machine(TB035.name).table.x_max_m  # 1 on the TB035
        entry, end, d, rise = s * DEMO_ENTRY_X_M, s * DEMO_END_X_M, s * DEMO_DEPTH_M, s * DEMO_CURL_RISE_M
        return [np.array(p) for p in ((entry, 0.0, DEMO_PITCH), (entry, -d, DEMO_PITCH), (end, -d, DEMO_PITCH),
                                      (end, -d + rise, DEMO_CURL_PITCH))]

    def joints_of(self, pose: np.ndarray, swing: float = 0.0) -> np.ndarray:
        """(4,) joint targets of tip pose ``pose`` (x, z, pitch) at ``swing`` [rad].

        Raises:
            GoalError: the pose is out of the machine's reach or joint limits.
        """
        q, ok = self.arm.inverse(np.asarray(pose, dtype=float))
        if not ok:
            raise GoalError(f"the tip pose {np.round(pose, 3).tolist()} (x, z [m], pitch [rad]) is out of the "
                            f"{self.machine.name.upper()}'s reach or joint limits")
        return np.r_[swing, q]

    def move_to(self, q: np.ndarray, *, tol: float = 0.01, timeout_s: float = 8.0) -> None:
        """A joint move to ``q`` (4,) until every joint is within ``tol`` rad (or ``timeout_s``)."""
        for _ in range(int(timeout_s / self.control_dt)):
            if np.all(np.abs(self.servos.track(q).q[:4] - q) <= tol):
                break

    def sample(self, swing: float) -> tuple[np.ndarray, np.ndarray]:
        """The tip pose (3,) and the soil's force in the arm plane (2,) [N] as the mind senses them now."""
        tip, _, f = plane_state(self.arm, self.force, self.servos.observe(), swing, np.zeros((4, 3)))
        return tip, f

    def go_to_start(self, pose: np.ndarray, swing: float) -> None:
        """Swing to ``swing`` with the tip :data:`ABOVE_M` above ``pose``, then down onto it."""
        start = self.joints_of(pose, swing)
        self.move_to(np.r_[swing, self.joints_of(pose + np.array([0.0, ABOVE_M, 0.0]))[1:]])
        self.move_to(start)

    def teleop_begin(self, observer) -> tuple[np.ndarray, float, np.ndarray]:
        """10 cm above the cut's entry at swing 0; ``observer`` (an
        :class:`~excavsim.record.excavator.ExcavatorRecorder`) sees the world after every control step."""
        if observer is not None:
            observer.started(self.world)
            self._observer = observer
            self.servos.step_hooks.append(observer.stepped)
        pose = self.cut()[0] + np.array([0.0, TELEOP_HEIGHT_M, 0.0])
        target = self.joints_of(pose, 0.0)
        self.move_to(target, tol=0.002)
        return pose, 0.0, target

    def teleop_target(self, pose: np.ndarray, swing: float) -> np.ndarray | None:
        try:
            return self.joints_of(pose, swing)
        except GoalError:
            return None

    def teleop_step(self, target: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        q = self.servos.track(target).q
        tip, f = self.sample(q[0])
        return tip, f, q[0]

    def teleop_end(self, n_keys: int | None) -> None:
        if self._observer is not None:
            self._observer.finished(self.world)


class CylinderArm(MachineAdapter):
    """The playback's side of a hydraulic excavator (the module docstring)."""

    impedance = TABLE_4_1
    table_header = "{:12s} {:20s} {:>17s} | {:>19s} | {:>10s} | {:>12s}".format(
        "soil", "controller", "pos RMS/max [cm]", "force RMS/peak [N]", "E", "bucket [m^3]")
    row_format = ("{soil:12s} {controller:20s} {pos_rms_cm:7.2f} / {pos_max_cm:6.2f}  | {force_rms_n:8.0f} / "
                  "{force_peak_n:8.0f} | {weighted_error:10.0f} | {bucket_m3:12.4f}")
    csv_columns = ("pos_rms_m", "pos_max_m", "force_rms_n", "force_peak_n", "demo_force_peak_n", "weighted_error",
                   "bucket_m3")
    swing_keys = True
    radial = "r"
    recorded_words = "recorded the session to"

    @property
    def experiment(self) -> str:
        return (f"demonstrate a cut on the {self.title}, replay it in the same, a stiffer and a softer soil with "
                "DiMaio 1998 Table 4.1's impedance (M 100 kg, B 5000 N s/m, K 1e4 / 1e5 N/m and variable)")

    @property
    def teleop_intro(self) -> str:
        return f"drive the {self.title}'s bucket from 10 cm above the demonstration cut"

    @property
    def teleop_source(self) -> str:
        return f"{self.title} teleoperation"

    def rig(self, soil: SoilParams, seed: int = 0) -> CylinderRig:
        return CylinderRig(self.machine, soil, seed)

    def record_demonstration(self, seed: int = 0, soil: str = DEMO_SOIL) -> Demonstration:
        """Drive the tip along :meth:`CylinderRig.cut` in ``soil`` (IK targets at the control rate) and take the
        measured tip pose and estimated soil force of every control step as the demonstration."""
        rig = self.rig(get_soil(soil), seed)
        path = rig.cut()
        rig.move_to(rig.joints_of(path[0] + np.array([0.0, ABOVE_M, 0.0])))
        rig.move_to(rig.joints_of(path[0]))
        poses, forces = [], []
        dt = rig.control_dt
        for a, b in zip(path[:-1], path[1:]):
            n = max(1, int(math.ceil(max(np.linalg.norm(b[:2] - a[:2]) / DEMO_SPEED_M_S, abs(b[2] - a[2]) / 1.0) / dt)))
            for k in range(1, n + 1):
                rig.servos.track(rig.joints_of(a + (b - a) * k / n))
                tip, f = rig.sample(0.0)
                poses.append(tip)
                forces.append(f)
        n = len(poses)
        entry, end, depth = path[0][0], path[2][0], -path[2][1]
        return Demonstration(np.arange(n) * dt, np.array(poses), np.array(forces), dt, 0.0,
                             f"{self.title} scripted cut {entry:.3g} -> {end:.3g} m at {depth:.3g} m deep, "
                             f"{DEMO_SPEED_M_S:g} m/s", soil)

    def demonstration_note(self, raw: Demonstration, played: Demonstration) -> str:
        return (f"{self.title} demonstration: {len(played.times)} samples ({played.times[-1]:.2f} s) in {played.soil}; "
                f"{played.source}; force peak {np.linalg.norm(played.force, axis=1).max():.0f} N")

    def session_recorder(self, record: str | None, url: str | None, seed: int):
        """An :class:`~excavsim.record.excavator.ExcavatorRecorder`: the machine's bodies and cylinders, the pit,
        the true terrain, the joints and cylinder forces."""
        from excavsim.record.excavator import ExcavatorRecorder

        return ExcavatorRecorder(record, seed=seed, live=url)
