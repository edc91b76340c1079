"""Hydraulic excavators as numbers: the cylinders' kinematics, their force and speed limits, the arm.

A backhoe's boom, stick (arm) and bucket are each driven by a hydraulic cylinder between two pins, and
its upper structure by a swing motor (DiMaio 1998 §4.2, Fig. 4.14: boom, stick and bucket act in one
vertical plane turned by the cabin angle). This module holds, numpy only, what the world's actuator
law (:mod:`excavsim.world.hydraulics`), the models' generator (``scripts/make_excavators.py``) and the
tests need:

* :class:`PinTriangle`: a cylinder whose pins sit on the two links either side of one joint (boom,
  stick). Its length is the third side of the triangle joint-pin-pin, by the law of cosines,
  ``L^2 = a^2 + b^2 - 2 a b cos(psi)`` with ``psi = q + offset`` the angle at the joint; its moment
  arm is ``dL/dq = a b sin(psi) / L``.
* :class:`BucketLinkage`: the bucket cylinder acts through the usual four-bar (a rocker pinned on the
  stick and a link to the bucket), since a cylinder pinned straight to the bucket cannot turn it
  through Table 4.2's 183 deg. Closed form: the bucket's pin ``P(q)`` turns with the bucket, the
  rocker's tip ``E`` is where the circles about the rocker pivot ``K`` and about ``P`` meet, the
  cylinder runs from ``C`` on the stick to ``E``; the moment arm ``dL/dq`` follows from differentiating
  the two circle constraints (a 2 x 2 linear solve), no finite differences.
* :class:`Cylinder` (bore, rod, count, stroke) and :class:`SwingMotor`: relief pressure gives the force
  (torque) limit, ``p A``, and pump flow the speed limit, ``Q / A``. Reflected to the joint, the torque
  limit is the relief force times the moment arm and the speed limit the cylinder speed over it, both
  pose-dependent (Singh 1995 §5.3 limits each joint's torque from its relief pressure; for a cylinder
  that limit becomes ``p A |dL/dq|``, different for extension and retraction).
* :func:`share_pump_flow`: Rowe 1997 §4.0, "one hydraulic pump powers two of the joints, and a second
  hydraulic pump powers the other two": when both functions of a pump ask for more than it delivers,
  neither reaches its own peak speed. The simplest law that has this property is used: both demands
  scaled by the same factor until their sum is the pump's flow (an idealized flow-sharing valve; real
  open-centre valves split by load pressure, which this ignores).
* :class:`ExcavatorArm`: the planar chain boom-stick-bucket turned by the swing, its closed-form
  forward kinematics (the bucket tip and the tip frame's blade direction) and its Jacobian.

Conventions (radians, metres, newtons): the arm plane's x points away from the swing axis, z up; the
boom angle is the boom's (foot pin to stick pin) angle above the horizontal, the stick and bucket angles
are each link's turn from the previous one, counter-clockwise (upwards) positive, as the MJCF's joints
about -y. At zero the boom, stick and bucket link (pin to tip) point along +x. Every function is
vectorized over leading dimensions of ``q``.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from excavsim.errors import ExcavsimError

GRAVITY = 9.81


def _rot(theta, v):
    """Rotate 2-vectors ``v`` (..., 2) counter-clockwise by ``theta`` (...)."""
    c, s = np.cos(theta), np.sin(theta)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)


@dataclasses.dataclass(frozen=True)
class Cylinder:
    """A double-acting hydraulic cylinder (or ``count`` of them side by side, as a mass excavator's boom).

    Attributes:
        bore_m, rod_m: piston and rod diameters [m].
        retracted_m: pin-to-pin length fully retracted [m]; stroke_m: the stroke [m].
        count: how many identical cylinders act together.
    """

    bore_m: float
    rod_m: float
    retracted_m: float
    stroke_m: float
    count: int = 1

    def __post_init__(self):
        if not (0 < self.rod_m < self.bore_m and self.retracted_m > self.stroke_m > 0 and self.count >= 1):
            raise ExcavsimError(f"cylinder: need 0 < rod < bore, retracted length > stroke > 0, count >= 1; "
                                f"given {self!r}")

    @property
    def extended_m(self) -> float:
        """Pin-to-pin length fully extended [m]."""
        return self.retracted_m + self.stroke_m

    @property
    def area_extend_m2(self) -> float:
        """Piston (cap-side) area of all the cylinders [m^2]: the area pressure pushes on to extend."""
        return self.count * math.pi / 4.0 * self.bore_m ** 2

    @property
    def area_retract_m2(self) -> float:
        """Annulus (rod-side) area of all the cylinders [m^2]: the area pressure pulls on to retract."""
        return self.count * math.pi / 4.0 * (self.bore_m ** 2 - self.rod_m ** 2)

    def force_limits(self, relief_pa: float) -> tuple[float, float]:
        """(pull, push) [N]: the largest retracting and extending forces at the relief pressure."""
        return relief_pa * self.area_retract_m2, relief_pa * self.area_extend_m2

    def speed_limits(self, flow_m3_s: float) -> tuple[float, float]:
        """(retract, extend) [m/s]: the speeds one pump's full flow gives (the flow limit)."""
        return flow_m3_s / self.area_retract_m2, flow_m3_s / self.area_extend_m2

    def flow(self, speed_m_s) -> np.ndarray:
        """The oil flow [m^3/s] a cylinder speed (positive: extending) takes, as a positive number."""
        v = np.asarray(speed_m_s, dtype=float)
        return np.where(v >= 0, v * self.area_extend_m2, -v * self.area_retract_m2)


@dataclasses.dataclass(frozen=True)
class SwingMotor:
    """The swing drive: a hydraulic motor through a reduction gear.

    Attributes:
        displacement_m3: motor displacement per revolution [m^3/rev].
        ratio: reduction from motor to upper structure [-].
        relief_pa: the swing circuit's relief pressure [Pa].
    """

    displacement_m3: float
    ratio: float
    relief_pa: float

    def torque_limit(self) -> float:
        """Largest swing torque [N m]: ``p D / (2 pi)`` times the ratio (losses ignored)."""
        return self.relief_pa * self.displacement_m3 / (2.0 * math.pi) * self.ratio

    def speed_limit(self, flow_m3_s: float) -> float:
        """Swing speed at a pump's full flow [rad/s]: ``2 pi Q / (D ratio)``."""
        return 2.0 * math.pi * flow_m3_s / (self.displacement_m3 * self.ratio)


@dataclasses.dataclass(frozen=True)
class PinTriangle:
    """A cylinder between a pin on the parent link and one on the child link of a joint.

    Attributes:
        parent_pin: (x, z) of the pin on the parent link, relative to the joint, in the parent's frame [m].
        child_pin: (x, z) of the pin on the child link, relative to the joint, in the child's frame at
            joint angle zero [m]; it turns with the joint.
    """

    parent_pin: tuple[float, float]
    child_pin: tuple[float, float]

    @property
    def a(self) -> float:
        """Joint to parent pin [m]."""
        return math.hypot(*self.parent_pin)

    @property
    def b(self) -> float:
        """Joint to child pin [m]."""
        return math.hypot(*self.child_pin)

    @property
    def offset(self) -> float:
        """``psi - q``: the angle at the joint from the parent pin to the child pin at q = 0 [rad]."""
        return math.atan2(self.child_pin[1], self.child_pin[0]) - math.atan2(self.parent_pin[1], self.parent_pin[0])

    def angle_at_joint(self, q) -> np.ndarray:
        """``psi``, the triangle's angle at the joint [rad]."""
        return np.asarray(q, dtype=float) + self.offset

    def length(self, q) -> np.ndarray:
        """Pin-to-pin length [m] by the law of cosines."""
        a, b = self.a, self.b
        return np.sqrt(a * a + b * b - 2.0 * a * b * np.cos(self.angle_at_joint(q)))

    def moment_arm(self, q) -> np.ndarray:
        """``dL/dq = a b sin(psi) / L`` [m/rad]: a cylinder force F gives the joint torque ``F dL/dq``."""
        return self.a * self.b * np.sin(self.angle_at_joint(q)) / self.length(q)

    def joint_angle(self, length, branch_q: float) -> np.ndarray:
        """The joint angle at pin-to-pin ``length`` [m], on the side of ``psi = 0`` that ``branch_q`` is on."""
        a, b = self.a, self.b
        cos_psi = np.clip((a * a + b * b - np.asarray(length, dtype=float) ** 2) / (2.0 * a * b), -1.0, 1.0)
        sign = 1.0 if math.sin(branch_q + self.offset) >= 0 else -1.0
        return sign * np.arccos(cos_psi) - self.offset


@dataclasses.dataclass(frozen=True)
class BucketLinkage:
    """The bucket's four-bar and cylinder, in the stick's frame with the bucket pin O at the origin.

    Attributes:
        rocker_pivot: K, the rocker's pin on the stick [m].
        cylinder_base: C, the bucket cylinder's pin on the stick [m].
        rocker_m: |KE|, the rocker (side link) [m]; link_m: |EP|, the link to the bucket [m].
        bucket_pin: P in the bucket's frame at bucket angle zero (origin at O) [m].
        branch: +1 or -1, which of the two circle intersections E is (the assembly mode).
    """

    rocker_pivot: tuple[float, float]
    cylinder_base: tuple[float, float]
    rocker_m: float
    link_m: float
    bucket_pin: tuple[float, float]
    branch: float = 1.0

    def points(self, q) -> tuple[np.ndarray, np.ndarray]:
        """(P, E), each (..., 2): the bucket's link pin and the rocker's tip at bucket angle q [m].

        Raises:
            ExcavsimError: the linkage cannot close at some q (the circles do not meet).
        """
        q = np.asarray(q, dtype=float)
        p = _rot(q, np.broadcast_to(np.asarray(self.bucket_pin, dtype=float), q.shape + (2,)))
        k = np.asarray(self.rocker_pivot, dtype=float)
        d_vec = p - k
        d = np.linalg.norm(d_vec, axis=-1)
        r1, r2 = self.rocker_m, self.link_m
        if np.any(d > r1 + r2) or np.any(d < abs(r1 - r2)):
            raise ExcavsimError("bucket linkage: the rocker and the link cannot reach the bucket pin at some "
                                f"bucket angle in {np.ravel(q)[:4]}...; check the pin geometry")
        along = (d * d + r1 * r1 - r2 * r2) / (2.0 * d)
        across = np.sqrt(np.maximum(r1 * r1 - along * along, 0.0))
        u = d_vec / d[..., None]
        n = np.stack([-u[..., 1], u[..., 0]], axis=-1)
        e = k + along[..., None] * u + self.branch * across[..., None] * n
        return p, e

    def rocker_angle(self, q) -> np.ndarray:
        """Angle of K->E in the stick's frame [rad]."""
        _, e = self.points(q)
        k = np.asarray(self.rocker_pivot)
        return np.arctan2(e[..., 1] - k[1], e[..., 0] - k[0])

    def link_angle(self, q) -> np.ndarray:
        """Angle of E->P in the stick's frame [rad]."""
        p, e = self.points(q)
        return np.arctan2(p[..., 1] - e[..., 1], p[..., 0] - e[..., 0])

    def length(self, q) -> np.ndarray:
        """Bucket cylinder's pin-to-pin length |CE| [m]."""
        _, e = self.points(q)
        return np.linalg.norm(e - np.asarray(self.cylinder_base), axis=-1)

    def moment_arm(self, q) -> np.ndarray:
        """``dL/dq`` [m/rad], from the circle constraints differentiated:
        ``(E - K) . dE = 0`` and ``(E - P) . (dE - dP) = 0`` with ``dP = perp(P) dq``."""
        q = np.asarray(q, dtype=float)
        p, e = self.points(q)
        k = np.asarray(self.rocker_pivot, dtype=float)
        c = np.asarray(self.cylinder_base, dtype=float)
        dp = np.stack([-p[..., 1], p[..., 0]], axis=-1)
        a1, a2 = e - k, e - p
        rhs2 = np.sum(a2 * dp, axis=-1)
        det = a1[..., 0] * a2[..., 1] - a1[..., 1] * a2[..., 0]
        # solve [a1; a2] dE = [0; rhs2]
        de = np.stack([-a1[..., 1] * rhs2, a1[..., 0] * rhs2], axis=-1) / det[..., None]
        ce = e - c
        return np.sum(ce * de, axis=-1) / np.linalg.norm(ce, axis=-1)

    def transmission_angles(self, q) -> tuple[np.ndarray, np.ndarray]:
        """Angles [rad] at E between rocker and link, and at P between link and the bucket's O->P."""
        p, e = self.points(q)
        k = np.asarray(self.rocker_pivot)
        ek, ep, po = k - e, p - e, -p

        def ang(u, v):
            cos = np.sum(u * v, -1) / (np.linalg.norm(u, axis=-1) * np.linalg.norm(v, axis=-1))
            return np.arccos(np.clip(cos, -1.0, 1.0))
        return ang(ek, ep), ang(-ep, po)


def share_pump_flow(demand_m3_s: np.ndarray, pumps: tuple[tuple[int, ...], ...], pump_flow_m3_s: float) -> np.ndarray:
    """Scale each pump's demanded flows so their sum is at most its flow (Rowe 1997 §4.0).

    Args:
        demand_m3_s: (n,) positive flows the functions ask for [m^3/s].
        pumps: for each pump, the indices of the functions it powers.
        pump_flow_m3_s: each pump's largest flow [m^3/s].

    Returns:
        (n,) the factors in (0, 1] by which each function's speed is scaled.
    """
    demand = np.asarray(demand_m3_s, dtype=float)
    if np.any(demand < 0):
        raise ExcavsimError(f"flow demands must be >= 0 m^3/s; given {demand!r}")
    scale = np.ones_like(demand)
    for group in pumps:
        idx = list(group)
        total = float(demand[idx].sum())
        if total > pump_flow_m3_s:
            scale[idx] = pump_flow_m3_s / total
    return scale


@dataclasses.dataclass(frozen=True)
class ExcavatorArm:
    """The digging chain: swing, boom, stick, bucket (joint order of ``q``: (..., 4)).

    Attributes:
        boom_foot: (x, z) of the boom's foot pin in the arm plane, from the swing axis at ground level [m].
        boom_m: foot pin to stick pin; stick_m: stick pin to bucket pin; bucket_m: bucket pin to tip [m].
        blade_angle: the blade's direction (heel to edge) in the bucket's frame, from the pin-to-tip line,
            counter-clockwise [rad] (the ``bucket_tip`` site's x axis).
        lower, upper: (4,) joint limits [rad].
    """

    boom_foot: tuple[float, float]
    boom_m: float
    stick_m: float
    bucket_m: float
    blade_angle: float
    lower: tuple[float, float, float, float]
    upper: tuple[float, float, float, float]

    def planar(self, q) -> np.ndarray:
        """(..., 3): the tip's radius r from the swing axis, height z, and the blade direction phi, the
        angle of the blade (heel to edge) counter-clockwise from the arm plane's +x [m, m, rad]."""
        q = np.asarray(q, dtype=float)
        t1 = q[..., 1]
        t12 = t1 + q[..., 2]
        t123 = t12 + q[..., 3]
        r = self.boom_foot[0] + self.boom_m * np.cos(t1) + self.stick_m * np.cos(t12) + self.bucket_m * np.cos(t123)
        z = self.boom_foot[1] + self.boom_m * np.sin(t1) + self.stick_m * np.sin(t12) + self.bucket_m * np.sin(t123)
        return np.stack([r, z, t123 + self.blade_angle], axis=-1)

    def tip(self, q) -> np.ndarray:
        """(..., 3) world position of the bucket tip (swing axis at the origin, swing about +z) [m]."""
        q = np.asarray(q, dtype=float)
        rz = self.planar(q)
        return np.stack([rz[..., 0] * np.cos(q[..., 0]), rz[..., 0] * np.sin(q[..., 0]), rz[..., 1]], axis=-1)

    def jacobian(self, q) -> np.ndarray:
        """(..., 3, 4): d tip / d q, the closed form's derivative (world frame)."""
        q = np.asarray(q, dtype=float)
        t1 = q[..., 1]
        t12 = t1 + q[..., 2]
        t123 = t12 + q[..., 3]
        l1, l2, l3 = self.boom_m, self.stick_m, self.bucket_m
        r = self.planar(q)[..., 0]
        # d r / d theta_i and d z / d theta_i for boom, stick, bucket
        dr3, dz3 = -l3 * np.sin(t123), l3 * np.cos(t123)
        dr2, dz2 = dr3 - l2 * np.sin(t12), dz3 + l2 * np.cos(t12)
        dr1, dz1 = dr2 - l1 * np.sin(t1), dz2 + l1 * np.cos(t1)
        c, s = np.cos(q[..., 0]), np.sin(q[..., 0])
        zero = np.zeros_like(r)
        rows = [[-r * s, dr1 * c, dr2 * c, dr3 * c],
                [r * c, dr1 * s, dr2 * s, dr3 * s],
                [zero, dz1, dz2, dz3]]
        return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)

    def within_limits(self, q) -> np.ndarray:
        """Whether each joint vector is inside the joint limits (...,)."""
        q = np.asarray(q, dtype=float)
        return np.all((q >= np.asarray(self.lower)) & (q <= np.asarray(self.upper)), axis=-1)
