"""The geometry of Rowe's script parameters (Rowe 1997 §4.2, Fig. 3): the truck (:class:`TruckSite`), the
boom's clearance angle over its side, where the soil leaves the bucket, and the two rules that choose the dump
and carry poses.

A machine's parameters need three poses from the planar kinematics (:class:`~excavsim.robot.kinematics.PlanarArm`):
the **carry** (the loaded bucket held while the swing turns), the **dump** (where the bucket opens over the
truck) and the boom's **clearance angles** over the truck's side at the carry and at the dump. Two rules
choose them:

* :class:`HeightDump` (the T3's §6.2 trial): the tip at a given height at the dump with the bucket open at a
  given pitch (inverse kinematics), the carry's stick where the dig left it and its bucket curled a little
  further, holding that pitch while the boom rises.
* :class:`ClearDump` (the 25 t loading a truck): the lowest dump whose opening bucket sweeps clear of the
  side and pours over the dump point (a search over the stick), the carry's stick the one that clears the
  side with the lowest boom.
"""

from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple, Protocol

import numpy as np

from excavsim.errors import GoalError
from excavsim.robot.kinematics import PlanarArm


@dataclasses.dataclass(frozen=True)
class TruckSite:
    """Where the load goes: the truck's centre in polar coordinates about the swing axis (Fig. 11; the T3's
    trial dumps on the ground at that target, the truck moved away, §6.2) and the truck's side the bucket
    must clear (Fig. 3).

    Attributes:
        r_d, theta_d: the truck's centre (the T3's desired pile position) [m, rad].
        side_z: height of the truck's side [m, world z]; with the truck moved away (§6.2) the
            parameters are still computed for it.
        half_width: half the bed's extent across the swing's path [m]: the swing reaches the truck's
            side at :attr:`edge_swing`.
        clearance: margin of the bucket's lowest point above the side [m].
        dump_z: height of the tip at the dump pose [m] (the :class:`HeightDump`
            rule's); None where the rule chooses it.
    """

    r_d: float
    theta_d: float
    side_z: float
    half_width: float
    clearance: float
    dump_z: float | None = None

    @property
    def edge_swing(self) -> float:
        """The swing angle at which the swing reaches the bed's near edge [rad]."""
        return self.theta_d - self.half_width / self.r_d


def clearance_boom_angle(arm: PlanarArm, stick: float, bucket: float, height_m: float, clearance_m: float, *,
                         outline: bool = True, solve: str = "closed") -> float:
    """Rowe 1997 Fig. 3: the lowest boom angle [rad] at which the bucket clears a truck side ``height_m``
    [m, above the ground] by ``clearance_m``, with the stick and bucket at ``stick`` and ``bucket`` [rad].

    Closed form (``solve="closed"``): with the stick and bucket held, every point ``p`` of the bucket (its
    outline, or only the tip when ``outline`` is False) turns rigidly about the boom's foot ``f`` as the boom
    turns, so its height is ``z_f + A sin(theta + psi)`` with ``A e^(i psi)`` the point's offset from the foot
    at boom angle zero (for the tip, ``A e^(i psi) = l1 + l2 e^(i q2) + l3 e^(i (q2 + q3 + blade))``, the link
    lengths); the point is at ``h + c`` where ``theta = asin((h + c - z_f) / A) - psi`` (the rising branch).
    The boom angle is the largest over the points.

    Bisection (``solve="bisect"``, the outline only): the first boom angle within the boom's range at which
    the bucket's lowest point is at ``h + c``, on the lowest point's height itself (the bucket rises with the
    boom over the range used). It also holds where part of the bucket never comes down to the side's height
    (a side well below a high shoulder, as the T3's at 0.5 m), which the closed form refuses. Where both apply
    they agree within 1e-15 rad, not bit for bit: the T3's parameters are computed by bisection, as they
    always were, so that its trials stay the same.

    Raises:
        GoalError: some point cannot reach that height (``A`` too short) or the angle is above the boom's limit
            (closed form); the bucket does not clear the side even with the boom at its limit (bisection).
        ValueError: ``solve`` is neither "closed" nor "bisect".
    """
    if solve == "bisect":
        return _clearance_by_bisection(arm, stick, bucket, height_m, clearance_m)
    if solve != "closed":
        raise ValueError(f"clearance_boom_angle: solve={solve!r}; allowed: 'closed', 'bisect'")
    pose = arm.forward(np.array([0.0, stick, bucket]))
    pts = arm.bucket_points(pose) if outline else pose[None, :2]
    rel = np.asarray(pts, float) - np.asarray(arm.shoulder_xz, float)
    a = np.hypot(rel[:, 0], rel[:, 1])
    psi = np.arctan2(rel[:, 1], rel[:, 0])
    s = (height_m + clearance_m - arm.shoulder_xz[1]) / a
    if np.any(np.abs(s) > 1.0):
        raise GoalError(f"the bucket cannot clear {height_m + clearance_m:.2f} m with the stick at "
                        f"{math.degrees(stick):.0f} deg and the bucket at {math.degrees(bucket):.0f} deg")
    theta = float(np.max((np.arcsin(s) - psi) / arm.joint_signs[0]))
    if theta > arm.upper[0]:
        raise GoalError(f"the boom would have to rise to {math.degrees(theta):.1f} deg to clear the truck, "
                        f"above its limit of {math.degrees(arm.upper[0]):.1f} deg")
    return theta


def _clearance_by_bisection(arm: PlanarArm, stick: float, bucket: float, side_z: float, clearance: float) -> float:
    def lowest(boom: float) -> float:
        pose = arm.forward(np.array([boom, stick, bucket]))
        pts = arm.bucket_points(pose)
        return float(np.min(pts[:, 1]))

    lo, hi = float(arm.lower[0]), float(arm.upper[0])
    if lowest(hi) < side_z + clearance:
        raise GoalError(f"the bucket cannot clear a truck side at {side_z:.2f} m with the stick at "
                        f"{math.degrees(stick):.0f} deg")
    # the bucket rises with the boom over the range used here: bisect for the first clear angle
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if lowest(mid) >= side_z + clearance:
            hi = mid
        else:
            lo = mid
    return hi


def pour_point(arm: PlanarArm, pitch: float) -> np.ndarray:
    """The bucket's lowest point relative to the tip (x, z) [m] at tip ``pitch`` [rad]: where the soil
    leaves the bucket."""
    pts = arm.bucket_points(np.array([0.0, 0.0, pitch]))
    return pts[int(np.argmin(pts[:, 1]))]


def bucket_for_pitch(arm: PlanarArm, boom: float, stick: float, pitch: float) -> float:
    """The bucket angle [rad] that puts the tip at ``pitch`` [rad] with the boom and stick at ``boom``, ``stick``."""
    p0 = float(arm.forward(np.array([boom, stick, 0.0]))[2])
    return float((pitch - p0 + math.pi) % (2.0 * math.pi) - math.pi) / float(arm.joint_signs[2])


class Poses(NamedTuple):
    """What a dump rule chooses (angles [rad]): the carry's boom, stick and bucket, the dump's boom and
    stick and the open bucket, and the boom's clearance angles over the truck's side at the carry's stick
    (``clear``) and at the dump's (``clear_dump``), both with the bucket at its carry angle."""

    boom_carry: float
    stick_carry: float
    bucket_carry: float
    boom_dump: float
    stick_dump: float
    bucket_open: float
    clear: float
    clear_dump: float


class DumpRule(Protocol):
    """How a machine chooses its carry and dump poses (:class:`HeightDump`, :class:`ClearDump`)."""

    def poses(self, arm: PlanarArm, site: TruckSite, dig_end: tuple[float, float, float], dump_r: float) -> Poses:
        """The poses for a load dug to ``dig_end`` (boom, stick, bucket [rad]) and dumped at radius ``dump_r`` [m].

        Raises:
            GoalError: the dump is out of reach or the bucket cannot clear the truck's side.
        """
        ...


@dataclasses.dataclass(frozen=True)
class HeightDump:
    """The dump at the site's height (the T3's §6.2 trial): the bucket's pour point (its lowest point with
    the bucket open, :func:`pour_point`) over ``dump_r`` with the tip at ``site.dump_z`` and at
    ``open_pitch``, by inverse kinematics; the carry keeps the dig's stick and curls the bucket
    ``capture_curl`` past the dig's end pitch, holding that pitch (the sum of the planar joint angles) as the
    boom rises to its clearance angle. Clearance angles by bisection (:func:`clearance_boom_angle`).

    Attributes:
        open_pitch: the tip pitch of the open bucket [rad] (a "magic number" of §4.2: assumed).
        capture_curl: how much further than the dig's end the bucket curls to carry the load [rad] (assumed).
    """

    open_pitch: float = math.radians(100.0)
    capture_curl: float = math.radians(10.0)

    def poses(self, arm: PlanarArm, site: TruckSite, dig_end: tuple[float, float, float], dump_r: float) -> Poses:
        if site.dump_z is None:
            raise GoalError("HeightDump: the site gives no dump height (dump_z); give one or use ClearDump")
        boom0, stick0, bucket0 = dig_end
        x_tip = dump_r - pour_point(arm, self.open_pitch)[0]
        q_dump, ok = arm.inverse(np.array([x_tip, site.dump_z, self.open_pitch]))
        if not ok:
            raise GoalError(f"the dump pose (tip {x_tip:.2f} m out, {site.dump_z:.2f} m up) is out of reach")
        stick_dump, bucket_open = float(q_dump[1]), float(q_dump[2])
        stick_carry = stick0
        boom_carry, bucket_carry = boom0, bucket0
        for _ in range(3):  # the clearance angle depends on the bucket's angle, which holds the pitch at it
            bucket_carry = bucket0 - self.capture_curl - (boom_carry - boom0)
            clear = clearance_boom_angle(arm, stick_carry, bucket_carry, site.side_z, site.clearance, solve="bisect")
            clear_dump = clearance_boom_angle(arm, stick_dump, bucket_carry, site.side_z, site.clearance,
                                              solve="bisect")
            boom_carry = max(clear, clear_dump, float(q_dump[0]))
        boom_dump = max(float(q_dump[0]), clear_dump)
        return Poses(boom_carry, stick_carry, bucket_carry, boom_dump, stick_dump, bucket_open, clear, clear_dump)


@dataclasses.dataclass(frozen=True)
class ClearDump:
    """The lowest dump clear of the side (the 25 t loading a truck): the open bucket's pour point over
    ``dump_r`` with the bucket's lowest point ``site.clearance`` above the truck's side over the whole arc
    it sweeps while it opens (:meth:`dump_pose`); the carry keeps the dig's bucket angle and takes, of the
    stick angles from the dig's to the dump's, the one that lets the bucket clear the side with the lowest
    boom (a dig that ended with the stick tucked in hangs the bucket low: carried so, it needed the boom
    within 2 deg of its limit and hit the side when the boom lagged); ties keep the stick nearer the dig's
    (assumed rule). Clearance angles by the closed form (:func:`clearance_boom_angle`).

    Attributes:
        pour_pitch, open_pitch: the tip's pitch in the middle of the pour and with the bucket open [rad] (the
            world's 25 t bucket pours between about 43 and 83 deg of pitch; "magic numbers" of §4.2, assumed).
    """

    pour_pitch: float = math.radians(63.0)
    open_pitch: float = math.radians(105.0)

    def dump_pose(self, arm: PlanarArm, site: TruckSite, dump_r: float,
                  bucket_carry: float) -> tuple[float, float, float]:
        """(boom, stick, bucket open) [rad] of the dump: the tip at radius ``dump_r`` [m] when the opening
        bucket is at the pour's pitch (the soil leaves over the tip there), and the whole arc the bucket sweeps
        while it opens from ``bucket_carry`` at least ``site.clearance`` above the truck's side (Fig. 3 for
        the dump). A search over the stick's angle: for each, the boom is the arc's clearance angle; the stick
        whose pour point lands nearest ``dump_r`` wins.

        Raises:
            GoalError: no stick angle puts the pour within 0.5 m of ``dump_r`` with the boom within its limits.
        """
        pour, opened = self.pour_pitch, self.open_pitch
        best = None
        for stick in np.linspace(arm.lower[1] + 0.05, arm.upper[1] - 0.05, 60):
            boom = float(arm.lower[0])
            try:
                for _ in range(2):  # the open angle depends on the boom
                    b_open = bucket_for_pitch(arm, boom, stick, opened)
                    arc = np.linspace(bucket_carry, min(b_open, float(arm.upper[2])), 12)
                    boom = max(clearance_boom_angle(arm, float(stick), float(b), site.side_z, site.clearance)
                               for b in arc)
            except GoalError:
                continue
            b_pour = bucket_for_pitch(arm, boom, stick, pour)
            r = float(arm.forward(np.array([boom, stick, b_pour]))[0])
            if best is None or abs(r - dump_r) < best[0]:
                best = (abs(r - dump_r), boom, float(stick), min(b_open, float(arm.upper[2])))
        if best is None or best[0] > 0.5:
            raise GoalError(f"no dump pose pours at r = {dump_r:.2f} m with the bucket clear of the truck's side "
                            f"({site.side_z + site.clearance:.2f} m)")
        return best[1], best[2], best[3]

    def poses(self, arm: PlanarArm, site: TruckSite, dig_end: tuple[float, float, float], dump_r: float) -> Poses:
        boom0, stick0, bucket0 = dig_end
        bucket_carry = bucket0
        boom_dump, stick_dump, bucket_open = self.dump_pose(arm, site, dump_r, bucket_carry)
        best = None
        for stick in np.linspace(stick0, stick_dump, 6):
            try:
                c = clearance_boom_angle(arm, float(stick), bucket_carry, site.side_z, site.clearance)
            except GoalError:
                continue
            if best is None or c < best[0] - 1e-3:
                best = (c, float(stick))
        if best is None:
            raise GoalError(f"the bucket cannot be carried over the truck's side ({site.side_z:.2f} m) from the "
                            f"dig's end pose {np.round(np.array(dig_end), 3).tolist()}")
        clear, stick_carry = best
        clear_dump = clearance_boom_angle(arm, stick_dump, bucket_carry, site.side_z, site.clearance)
        boom_carry = min(max(clear, clear_dump, boom_dump), float(arm.upper[0]))
        return Poses(boom_carry, stick_carry, bucket_carry, boom_dump, stick_dump, bucket_open, clear, clear_dump)
