"""The trenching machines: what the loop needs to know of a machine beside its MJCF, in a few names.

A trenching machine is a model folder (``models/<name>/scene.xml``: the machine beside its soil, with the
soil model's bucket names, the ``ft_mount`` F/T site and sensors, the ``scanner`` site and the ``home`` and
``park`` keyframes, see docs/concepts/own-machine.md) plus a :class:`Machine`: its joints in the order the
world reports them, which one is the waist (swing), which three form the planar digging chain
(Singh 1995 §4.3.3: only these move while digging), which others are held still and where, the extent of
its reachability table, and for a hydraulic excavator its cylinders (:class:`~excavsim.robot.excavators.ExcavatorSpec`),
from which its joint-torque limits follow at each pose (:meth:`Machine.torque_limits`).

The loop reads the planar chain from the model with these joint names
(:func:`~excavsim.robot.extract.arm_from_model`), the home and park poses from the model's keyframes
(:func:`~excavsim.readouts.keyframe_qpos`), and the executor runs the dig script on the named joints; the
world builds the machine's physics by its name (:func:`excavsim.world.machines.make_world`). So a machine is
data here, not a branch of the code.

Two kinds today: the T3 (six joints, relief-pressure torque limits constant per joint, ``configs/robot.yaml``)
and the hydraulic excavators of :mod:`excavsim.robot.excavators` (``tb035``, ``excavator_25t``: swing, boom,
stick and bucket, each cylinder's torque limit the relief pressure times its piston or annulus area times
its moment arm, which varies with the pose).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from excavsim import constants
from excavsim.errors import ConfigError
from excavsim.robot.excavators import CHAIN_JOINTS, MACHINES as EXCAVATORS, ExcavatorSpec
from excavsim.robot.reachability import TableSpec


@dataclasses.dataclass(frozen=True)
class Machine:
    """A trenching machine's description (see the module docstring).

    Attributes:
        name: the model folder's name (``models/<name>/``).
        joints: every joint the world reports, in its order; the waist first, then the planar three.
        waist: the joint that turns the arm's plane (the T3's waist, an excavator's swing).
        planar: the planar digging chain's three joints (shoulder/boom, elbow/stick, wrist pitch/bucket).
        held: joints held at fixed angles while digging, with those angles [rad] (the T3's wrist yaw and roll).
        table: the reachability table's extent and resolution (Singh 1995 App. A1-3) for this machine's reach.
        hydraulics: the excavator's cylinders and relief pressure; None for a machine whose torque limits
            are constants of its model (the T3's actuators' ``forcerange``).
        extract: whether :func:`~excavsim.robot.extract.arm_from_model` is given the joint names (False: the
            T3, whose names are its default).
        home, park: the poses before a dig (over the soil) and during a scan (out of the scanner's view), in
            :attr:`joints` order [rad]; None takes the model's keyframe of that name.
        force_reading: how the mind reads the soil's force on the bucket: ``ft`` (the wrist F/T at
            ``ft_mount``, :class:`~excavsim.sensing.ft.ForceSensor`) or ``cylinders`` (the cylinders'
            pressures through the arm's statics, :class:`~excavsim.sensing.pressure.CylinderForceReading`:
            an excavator's ``ft_mount`` on the bucket pin also carries the linkage's push).
        angle_bound_rad, speed_bound_rad_s: the bounds of its joints' angles [rad] and speeds [rad/s] in a
            joint-level environment's observation (:class:`~excavsim.envs.joint_core.JointCore`; readings
            beyond are clipped): the T3's waist turns nearly a full circle, an excavator's joints stay
            within half of one (DiMaio 1998 Table 4.2 on the TB035) and move slower.
    """

    name: str
    joints: tuple[str, ...]
    waist: str
    planar: tuple[str, str, str]
    held: tuple[tuple[str, float], ...] = ()
    table: TableSpec = TableSpec()
    hydraulics: ExcavatorSpec | None = None
    extract: bool = True
    home: tuple[float, ...] | None = None
    park: tuple[float, ...] | None = None
    force_reading: str = "ft"
    angle_bound_rad: float = 2 * math.pi
    speed_bound_rad_s: float = 50.0

    @property
    def chain_joints(self) -> tuple[str, ...] | None:
        """The four joint names :func:`~excavsim.robot.extract.arm_from_model` takes (waist and the planar
        three; None for the T3, whose names are the extraction's default)."""
        return (self.waist, *self.planar) if self.extract else None

    def index(self, names) -> list[int]:
        """Positions of joint ``names`` in :attr:`joints`."""
        return [self.joints.index(n) for n in names]

    def torque_limits(self, q) -> np.ndarray:
        """(..., 3, 2) the planar joints' (lower, upper) torque limits at planar joint angles ``q`` (..., 3)
        [N m]: for cylinders relief pressure x area x moment arm (Singh 1995 §5.3 for cylinders,
        :meth:`~excavsim.robot.excavators.ExcavatorSpec.joint_torque_limits`).

        Raises:
            ConfigError: the machine's limits are its model's constants (no hydraulics given).
        """
        if self.hydraulics is None:
            raise ConfigError(f"machine {self.name}: its torque limits are its model's actuator force ranges, "
                              "not a function of the pose")
        q = np.asarray(q, dtype=float)
        full = np.concatenate([np.zeros(q.shape[:-1] + (1,)), q], axis=-1)
        return self.hydraulics.joint_torque_limits(full)[..., 1:, :]


T3 = Machine("t3", constants.JOINTS, constants.WAIST_JOINT, constants.PLANAR_JOINTS,
             held=(("wrist_yaw_joint", 0.0), ("wrist_roll_joint", 0.0)), extract=False)

# The excavators' tables cover their pits: tips from the pit's floor to above the cab, out to the full reach.
_TABLES = {
    "tb035": TableSpec(z_min_m=-1.2, z_max_m=3.5, x_min_m=-0.5, x_max_m=5.2, dx_scan_m=0.03),
    "excavator_25t": TableSpec(z_min_m=-3.0, z_max_m=8.0, dz_m=0.02, x_min_m=-1.0, x_max_m=11.5, dx_scan_m=0.05),
}

# Trenching's home poses: the bucket raised over the pit, ready to swing and reach an entry (the models'
# ``home`` keyframes rest the bucket on the ground). The TB035's: the tip 0.7 m above the ground 2.6 m out,
# the blade 17 deg up (its IK); the 25 t machine's: 1.8 m up 6.5 m out, the same blade angle. Park is the keyframe.
_HOMES = {"tb035": (0.0, 0.743459, -1.755837, -0.918266), "excavator_25t": (0.0, 0.680546, -1.503837, -1.101589)}

MACHINES: dict[str, Machine] = {"t3": T3, **{
    name: Machine(name, CHAIN_JOINTS, CHAIN_JOINTS[0], CHAIN_JOINTS[1:], table=_TABLES[name], hydraulics=spec,
                  home=_HOMES[name], force_reading="cylinders", angle_bound_rad=math.pi, speed_bound_rad_s=10.0)
    for name, spec in EXCAVATORS.items()}}
"""The trenching machines by name: the T3 and the hydraulic excavators."""


def get_machine(name: str) -> Machine:
    """The trenching machine called ``name``.

    Raises:
        ConfigError: no such machine; the message lists the allowed ones.
    """
    if name not in MACHINES:
        raise ConfigError(f"unknown trenching machine {name!r}; allowed: {', '.join(MACHINES)}")
    return MACHINES[name]
