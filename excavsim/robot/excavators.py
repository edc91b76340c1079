"""The excavator machines' numbers: one :class:`ExcavatorSpec` per model folder (``models/<name>/``).

Each spec holds every dimension of the machine: the planar chain (:class:`~excavsim.robot.cylinders.ExcavatorArm`),
the cylinders' pins, bores and strokes, the bucket linkage, the swing motor, relief pressures and pump
flows, masses and the bucket's profile. ``scripts/make_excavators.py`` writes the MJCF from it, and the
tests hold MuJoCo's kinematics of the written files against the closed forms computed from it, so
the numbers exist once. Every number's source (or "assumed") is in the model folder's README.

Two machines:

* ``tb035``: the Takeuchi TB035 mini-excavator of DiMaio 1998 §4.2 (Fig. 4.13). Its joint limits are
  Table 4.2's exactly; its link lengths, masses and hydraulics are class values (assumed: the thesis
  refers to Tafazoli 1997 for the specifications, which we do not have).
* ``excavator_25t``: a 25 t class mass excavator, the class of Rowe 1997 §6.1's testbed ("a 25 ton
  hydraulic excavator"); boom 6.15 m, stick 3.2 m and the 1.1 m^3 bucket of a reach-boom
  configuration of the class, other numbers assumed.

Pin geometry: the pins were chosen (not measured) so that each cylinder's stroke spans exactly the
joint's range with a retracted length above the stroke, i.e. a buildable cylinder (retracted/extended
length ratio below 1.8); :meth:`ExcavatorSpec.check` enforces that.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from excavsim import constants
from excavsim.errors import ConfigError, ModelError
from excavsim.robot.cylinders import BucketLinkage, Cylinder, ExcavatorArm, PinTriangle, SwingMotor

MPA = 1e6
LPM = 1e-3 / 60.0  # one litre per minute [m^3/s]

# Which functions each pump powers (indices into FUNCTIONS). Rowe 1997 §4.0 says one pump powers two of
# the joints and a second the other two without naming them; boom + bucket on one and stick + swing on
# the other is the usual split of a two-pump excavator (assumed).
# DiMaio 1998 Table 4.2: the TB035's joint limits (boom, stick, bucket) [rad]
TABLE_4_2_BOOM = (-1.085, 1.2075)
TABLE_4_2_STICK = (-2.6927, -0.6102)
TABLE_4_2_BUCKET = (-2.6843, 0.5182)
FUNCTIONS = ("swing", "boom", "stick", "bucket")
# The joints of each function, in this order; the planar chain is the last three.
CHAIN_JOINTS = tuple(f"{f}_joint" for f in FUNCTIONS)
PUMPS = ((1, 3), (0, 2))


@dataclasses.dataclass(frozen=True)
class BucketShape:
    """The bucket's side profile (the T3 bucket's shape: blade, arc, back wall), in its tip frame.

    Attributes:
        width_m: inner width; blade_m: flat floor from the cutting edge; arc_m: floor-to-back radius;
        back_m: top of the back wall above the blade's plane; pin_m: the bucket pin's height above the
        blade's plane, on the back wall's line [m]; mass_kg: the empty bucket.
    """

    width_m: float
    blade_m: float
    arc_m: float
    back_m: float
    pin_m: float
    mass_kg: float

    @property
    def depth_m(self) -> float:
        """Cutting edge to back wall along the blade [m]."""
        return self.blade_m + self.arc_m

    def profile(self, n_arc: int = 4) -> np.ndarray:
        """(n, 2) profile points (x along the blade, heel to edge; z into the bucket), the edge first."""
        pts = [(0.0, 0.0), (-self.blade_m, 0.0)]
        cx, cz, r = -self.blade_m, self.arc_m, self.arc_m
        for a in np.linspace(-np.pi / 2, -np.pi, n_arc + 1)[1:]:
            pts.append((cx + r * math.cos(a), cz + r * math.sin(a)))
        pts.append((-self.depth_m, self.back_m))
        return np.asarray(pts)

    def struck_capacity_m3(self) -> float:
        """Area between the profile and the strike line (back top to edge), times the width [m^3]."""
        r = self.arc_m
        return (self.depth_m * self.back_m / 2.0 - (r * r - math.pi * r * r / 4.0)) * self.width_m

    @property
    def pin_to_tip_m(self) -> float:
        """The bucket link: pin to cutting edge [m]."""
        return math.hypot(self.depth_m, self.pin_m)

    @property
    def blade_angle(self) -> float:
        """The blade's direction (heel to edge) from the pin-to-tip line, counter-clockwise [rad]."""
        return -math.atan2(self.pin_m, self.depth_m)

    def to_bucket_frame(self, xz_tip: np.ndarray) -> np.ndarray:
        """Tip-frame points (n, 2) to the bucket body's (x, z), origin at the pin, x towards the tip."""
        a = self.blade_angle
        xt, zt = np.array([math.cos(a), math.sin(a)]), np.array([math.sin(a), -math.cos(a)])
        edge = np.array([self.pin_to_tip_m, 0.0])
        xz_tip = np.atleast_2d(xz_tip)
        return edge + xz_tip[:, :1] * xt + xz_tip[:, 1:2] * zt


@dataclasses.dataclass(frozen=True)
class ExcavatorSpec:
    """All the numbers of one excavator model (see the module docstring): the machine's description for
    the rest of the package (its files :attr:`model_xml` and :attr:`scene_xml`, the planar chain
    :attr:`arm` and its joints :data:`CHAIN_JOINTS`, the tool :attr:`bucket`, the joint limits, and the
    pose-dependent torque and speed limits its hydraulics give).

    Attributes:
        name: the model folder's name.
        arm: the planar chain and joint limits (swing, boom, stick, bucket).
        upper_z_m: the swing bearing's height (the upper structure's frame) [m].
        boom_pins, stick_pins: the boom and stick cylinders' pins.
        linkage: the bucket's four-bar and cylinder pins (stick frame, bucket pin at the origin).
        boom_cyl, stick_cyl, bucket_cyl: the cylinders (strokes filled in by :meth:`with_strokes`).
        swing_motor: the swing drive.
        relief_pa: main relief pressure [Pa]; pump_flow_m3_s: each pump's largest flow [m^3/s].
        masses_kg: upper, boom, stick, rocker, link (the bucket's is in ``bucket``).
        bucket: the bucket's shape.
        ref: (4,) the reference pose the MJCF bodies are written in (qpos0) [rad].
        servo_time_s: the cylinder servo's damping time (kv / kp) [s]; servo_error_m: the length error
            at which the servo reaches the relief force (kp = push force / error) [m].
    """

    name: str
    arm: ExcavatorArm
    upper_z_m: float
    boom_pins: PinTriangle
    stick_pins: PinTriangle
    linkage: BucketLinkage
    boom_cyl: Cylinder
    stick_cyl: Cylinder
    bucket_cyl: Cylinder
    swing_motor: SwingMotor
    relief_pa: float
    pump_flow_m3_s: float
    masses_kg: dict
    bucket: BucketShape
    ref: tuple[float, float, float, float]
    servo_error_m: float = 0.01
    servo_time_s: float = 0.05

    @property
    def model_xml(self):
        """The machine-only MJCF (``models/<name>/<name>.xml``)."""
        return constants.MODELS_DIR / self.name / f"{self.name}.xml"

    @property
    def scene_xml(self):
        """The machine beside its soil pit (``models/<name>/scene.xml``)."""
        return constants.MODELS_DIR / self.name / "scene.xml"

    def cylinder_length(self, function: str, q) -> np.ndarray:
        """Pin-to-pin length [m] of ``function``'s cylinder (boom, stick, bucket) at its joint angle ``q``."""
        return self._geometry(function).length(q)

    def moment_arm(self, function: str, q) -> np.ndarray:
        """``dL/dq`` [m/rad] of ``function``'s cylinder at its joint angle ``q``."""
        return self._geometry(function).moment_arm(q)

    def _geometry(self, function: str):
        geometry = {"boom": self.boom_pins, "stick": self.stick_pins, "bucket": self.linkage}
        if function not in geometry:
            raise ConfigError(f"unknown cylinder {function!r}; allowed: {', '.join(geometry)}")
        return geometry[function]

    def cylinder(self, function: str) -> Cylinder:
        """The cylinder of ``function`` (boom, stick, bucket)."""
        return {"boom": self.boom_cyl, "stick": self.stick_cyl, "bucket": self.bucket_cyl}[function]

    def rest_state(self, q) -> tuple[list[float], list[float]]:
        """The model's state at rest at joint angles ``q`` (4,) (swing, boom, stick, bucket) [rad]: the joint
        positions in the MJCF's tree order (swing, boom, stick, bucket, and the bucket linkage's rocker and
        link, which close the four-bar) [rad], and the servos' activations (the swing angle and each cylinder's
        length from the reference pose :attr:`ref`) [rad, m]: the scene's keyframes, and a start pose set
        without a simulated move."""
        rho, lam = float(self.linkage.rocker_angle(q[3])), float(self.linkage.link_angle(q[3]))
        qpos = [q[0], q[1], q[2], q[3], rho, lam - rho]
        act = [q[0] - self.ref[0]] + [float(self.cylinder_length(fn, q[j]) - self.cylinder_length(fn, self.ref[j]))
                                      for j, fn in ((1, "boom"), (2, "stick"), (3, "bucket"))]
        return qpos, act

    def joint_torque_limits(self, q) -> np.ndarray:
        """(..., 4, 2) the joints' (lower, upper) torque limits at pose ``q`` (..., 4) [N m]: the relief
        forces times the moment arm (pose-dependent, Singh 1995 §5.3 for cylinders), the swing motor's
        torque for the swing."""
        q = np.asarray(q, dtype=float)
        out = np.empty(q.shape + (2,))
        t = self.swing_motor.torque_limit()
        out[..., 0, :] = (-t, t)
        for j, f in enumerate(("boom", "stick", "bucket"), start=1):
            pull, push = self.cylinder(f).force_limits(self.relief_pa)
            m = self.moment_arm(f, q[..., j])
            a, b = push * m, -pull * m
            out[..., j, 0], out[..., j, 1] = np.minimum(a, b), np.maximum(a, b)
        return out

    def planner_torque_limits(self, lower=None, upper=None, n: int = 181) -> np.ndarray:
        """(3,) one torque limit per planar joint (boom, stick, bucket) [N m] for a planner whose force
        constraint takes constants (Singh 1995 §5.3.3, the T3's relief torques): the smallest of
        :meth:`joint_torque_limits`' magnitudes, both directions, over each joint's range (or the sub-range
        ``lower``..``upper`` (3,) the digs use). Conservative: the cylinder gives more in most poses."""
        lo = np.asarray(self.arm.lower[1:] if lower is None else lower, dtype=float)
        hi = np.asarray(self.arm.upper[1:] if upper is None else upper, dtype=float)
        if lo.shape != (3,) or hi.shape != (3,) or np.any(lo > hi) or np.any(lo < np.asarray(self.arm.lower[1:])) \
                or np.any(hi > np.asarray(self.arm.upper[1:])):
            raise ConfigError(f"{self.name}: the sub-range must be 3 intervals within the joint limits "
                                f"{self.arm.lower[1:]} .. {self.arm.upper[1:]} rad; given {lower!r} .. {upper!r}")
        out = np.empty(3)
        for j in range(3):
            q = np.tile(np.asarray(self.ref, dtype=float), (n, 1))
            q[:, j + 1] = np.linspace(lo[j], hi[j], n)
            out[j] = np.abs(self.joint_torque_limits(q)[:, j + 1, :]).min()
        return out

    def joint_speed_limits(self, q) -> np.ndarray:
        """(..., 4) each joint's largest speed with a pump's full flow to itself alone [rad/s] (the slower
        of extension and retraction: ``v / |dL/dq|``)."""
        q = np.asarray(q, dtype=float)
        out = np.empty(q.shape)
        out[..., 0] = self.swing_motor.speed_limit(self.pump_flow_m3_s)
        for j, f in enumerate(("boom", "stick", "bucket"), start=1):
            v = min(self.cylinder(f).speed_limits(self.pump_flow_m3_s))
            out[..., j] = v / np.abs(self.moment_arm(f, q[..., j]))
        return out

    def stroke_ends(self, function: str) -> tuple[float, float]:
        """(shortest, longest) pin-to-pin length over the joint's range [m]."""
        j = FUNCTIONS.index(function)
        q = np.linspace(self.arm.lower[j], self.arm.upper[j], 721)
        length = self.cylinder_length(function, q)
        return float(length.min()), float(length.max())

    def with_strokes(self) -> ExcavatorSpec:
        """This spec with each cylinder's retracted length and stroke those its pins give over the range."""
        update = {}
        for f in ("boom", "stick", "bucket"):
            lo, hi = self.stroke_ends(f)
            update[f"{f}_cyl"] = dataclasses.replace(self.cylinder(f), retracted_m=lo, stroke_m=hi - lo)
        return dataclasses.replace(self, **update)

    def check(self) -> None:
        """Raise unless each cylinder's length is monotonic over its joint's range (the moment arm keeps
        its sign and stays away from zero) and buildable (extended / retracted below 1.8).

        Raises:
            ModelError: naming the cylinder and what is wrong.
        """
        for j, f in enumerate(("boom", "stick", "bucket"), start=1):
            q = np.linspace(self.arm.lower[j], self.arm.upper[j], 721)
            m = self.moment_arm(f, q)
            if not (np.all(m > 0) or np.all(m < 0)):
                raise ModelError(f"{self.name}: the {f} cylinder's moment arm changes sign over the joint range")
            lo, hi = self.stroke_ends(f)
            if hi / lo >= 1.8:
                raise ModelError(f"{self.name}: the {f} cylinder's extended/retracted length {hi / lo:.2f} >= 1.8")
        t1, t2 = self.linkage.transmission_angles(np.linspace(self.arm.lower[3], self.arm.upper[3], 721))
        worst = min(t1.min(), t2.min(), math.pi - t1.max(), math.pi - t2.max())
        if worst < math.radians(20):
            raise ModelError(f"{self.name}: the bucket linkage's transmission angle falls to "
                                f"{math.degrees(worst):.0f} deg (at least 20 deg needed)")


def _triangle(a: float, parent_deg: float, b: float, psi_mid_deg: float, q_mid: float) -> PinTriangle:
    """Pins at ``a`` from the joint at ``parent_deg`` on the parent and ``b`` on the child, placed so that
    the triangle's angle at the joint is ``psi_mid_deg`` in the middle of the range ``q_mid``."""
    pa = math.radians(parent_deg)
    child = pa + math.radians(psi_mid_deg) - q_mid
    return PinTriangle((a * math.cos(pa), a * math.sin(pa)), (b * math.cos(child), b * math.sin(child)))


def _linkage(stick_m: float, shift: float) -> BucketLinkage:
    """The bucket four-bar, in units of the stick's length (one shape for both machines, found by a
    random search for the largest smallest moment arm with transmission angles above 40 deg over
    Table 4.2's bucket range; assumed, not measured). ``shift`` [rad]: the bucket's range is Table 4.2's
    moved by this much, and the bucket's pin turned back by it, so the linkage works the same."""
    s = stick_m
    pin = np.array([-0.007 * s, 0.164 * s])
    c, sn = math.cos(-shift), math.sin(-shift)
    pin = (c * pin[0] - sn * pin[1], sn * pin[0] + c * pin[1])
    return BucketLinkage(rocker_pivot=(-0.116 * s, -0.089 * s), cylinder_base=(-0.811 * s, 0.151 * s),
                         rocker_m=0.296 * s, link_m=0.180 * s, bucket_pin=pin, branch=1.0)


def _spec(name, *, foot, upper_z, boom, stick, lower, upper, boom_pins, stick_pins, cyl, motor, relief, flow,
          masses, bucket, servo_error) -> ExcavatorSpec:
    arm = ExcavatorArm(boom_foot=foot, boom_m=boom, stick_m=stick, bucket_m=bucket.pin_to_tip_m,
                       blade_angle=bucket.blade_angle, lower=lower, upper=upper)
    mid = tuple(0.0 if j == 0 else 0.5 * (lower[j] + upper[j]) for j in range(4))
    boom_tri = _triangle(*boom_pins, psi_mid_deg=90.0, q_mid=mid[1])
    stick_tri = _triangle(*stick_pins, psi_mid_deg=-90.0, q_mid=mid[2])
    # the strokes are placeholders until with_strokes() fits them to the pins and the range
    placeholder = {k: Cylinder(bore_m=b, rod_m=r, retracted_m=2.0, stroke_m=1.0, count=n)
                   for k, (b, r, n) in cyl.items()}
    spec = ExcavatorSpec(name=name, arm=arm, upper_z_m=upper_z, boom_pins=boom_tri, stick_pins=stick_tri,
                         linkage=_linkage(stick, lower[3] - TABLE_4_2_BUCKET[0]), boom_cyl=placeholder["boom"],
                         stick_cyl=placeholder["stick"],
                         bucket_cyl=placeholder["bucket"], swing_motor=motor, relief_pa=relief,
                         pump_flow_m3_s=flow, masses_kg=masses, bucket=bucket, ref=mid, servo_error_m=servo_error)
    spec = spec.with_strokes()
    spec.check()
    return spec


TB035 = _spec(
    "tb035", foot=(0.35, 0.95), upper_z=0.55, boom=2.40, stick=1.40,
    # DiMaio 1998 Table 4.2 (boom, stick, bucket); the swing turns freely (limits at +-pi for the model)
    lower=(-math.pi, TABLE_4_2_BOOM[0], TABLE_4_2_STICK[0], TABLE_4_2_BUCKET[0]),
    upper=(math.pi, TABLE_4_2_BOOM[1], TABLE_4_2_STICK[1], TABLE_4_2_BUCKET[1]),
    boom_pins=(0.30, -100.0, 1.00), stick_pins=(1.10, 165.0, 0.33),
    cyl={"boom": (0.080, 0.045, 1), "stick": (0.070, 0.040, 1), "bucket": (0.065, 0.040, 1)},
    motor=SwingMotor(displacement_m3=25e-6, ratio=160.0, relief_pa=17.0 * MPA),
    relief=20.6 * MPA, flow=36.0 * LPM,
    masses={"base": 1500.0, "upper": 1300.0, "boom": 180.0, "stick": 90.0, "rocker": 6.0, "link": 6.0},
    bucket=BucketShape(width_m=0.55, blade_m=0.27, arc_m=0.18, back_m=0.55, pin_m=0.58, mass_kg=80.0),
    servo_error=0.01,
)

EXCAVATOR_25T = _spec(
    "excavator_25t", foot=(0.20, 2.05), upper_z=1.20, boom=6.15, stick=3.20,
    # bucket: Table 4.2's range moved 0.1 rad open, so that Rowe 1997 Fig. 4's 30-35 deg dump is inside
    lower=(-math.pi, -1.0, -2.6, TABLE_4_2_BUCKET[0] + 0.1), upper=(math.pi, 1.0, -0.55, TABLE_4_2_BUCKET[1] + 0.1),
    boom_pins=(0.90, -100.0, 2.70), stick_pins=(2.60, 165.0, 0.75),
    cyl={"boom": (0.140, 0.100, 2), "stick": (0.150, 0.105, 1), "bucket": (0.135, 0.095, 1)},
    motor=SwingMotor(displacement_m3=150e-6, ratio=127.0, relief_pa=28.0 * MPA),
    relief=34.3 * MPA, flow=214.0 * LPM,
    masses={"base": 10000.0, "upper": 13000.0, "boom": 2000.0, "stick": 1000.0, "rocker": 60.0, "link": 60.0},
    bucket=BucketShape(width_m=1.20, blade_m=0.70, arc_m=0.45, back_m=1.45, pin_m=1.50, mass_kg=950.0),
    servo_error=0.01,
)

MACHINES = {s.name: s for s in (TB035, EXCAVATOR_25T)}


def get_machine(name: str) -> ExcavatorSpec:
    """The excavator spec called ``name``.

    Raises:
        ConfigError: no such machine; the message lists the known ones.
    """
    if name not in MACHINES:
        raise ConfigError(f"unknown excavator {name!r}; allowed: {', '.join(MACHINES)}")
    return MACHINES[name]
