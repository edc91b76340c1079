"""The two loading machines of the 2-D loading world (Singh 1995 §4.1.3, §4.2, App. A1-2).

Both are planar, in the world's (x, z) plane: x horizontal, from the machine towards the pile, z up, the
ground at z = 0. A tip pose is (x, z, phi): the bucket tip and the direction ``phi`` of its floor, from the
heel to the cutting edge, counter-clockwise from +x [m, m, rad] (phi = 0: floor level, edge towards the pile).

* :class:`FrontLoader`, the P-R-R manipulator of Fig. 30 / Fig. A-5: the vehicle's travel is a prismatic
  joint ``d1`` and the boom and bucket are revolute joints ``theta2``, ``theta3``; the base moves during
  the dig. Its kinematics are the Denavit-Hartenberg parameters of Table A1-3 (modified, Craig's
  convention: rows alpha_{i-1}, a_{i-1}, theta_i, d_i; :func:`dh_transform`), with the world transform
  (A1 21). Multiplying the table's rows out (:meth:`FrontLoader.forward_dh`, with theta_1 = 0 as
  ``0_1T`` of (A1 20) has it) gives

      x = l2 - d1 + l3 S2 + l4 S23,   z = -l1 - l3 C2 - l4 C23,   x_4 = (S_{23-mu}, -C_{23-mu})

  (:meth:`FrontLoader.forward`). The thesis' printed transform ``1_2T`` of (A1 20) and its forward
  kinematics (A1 22) use theta_2 and a_1 = +l1 where the table has pi + theta_2 and a_1 = -l1: the same
  chain under l1 -> -l1, theta2 -> theta2 + pi, which turns every l1, l3, l4 term's sign. (A1 22) also
  prints ``l3 S2`` in its second row where (24) has ``-l3 C2``; we follow the table, as written, and a test
  holds the closed form equal to the product of its rows. So ``l1`` is minus the shoulder's height above
  frame 1 (which (A1 21) puts at ground level): a shoulder 1.6 m up is l1 = -1.6 m. The inverse is
  (A1 25-31) for the table's signs: theta23 from the orientation, theta2 from the height (two solutions,
  the boom's two sides; the one within the joint limits, the smaller theta2 first), d1 from x.

  The sign of mu: the tip frame is the bucket link turned by -mu (the table's row 4), so the link from the
  pin to the tip points mu counter-clockwise of the floor and the pin lies ``l4 sin(mu)`` *below* the floor's
  line for mu > 0: under the bucket, 0.3-0.5 m under the ground in digs along it. Neither (A1 25) nor the
  table fixes the sign (both hold for either; Fig. A-5 is not in our copy of the text), so the bucket's shape
  decides: a loader's pin is above and behind its floor, so ``configs/pile_loading_planar.yaml`` has mu = -20 deg (the pin
  0.34 m above the floor's line, 0.94 m behind the edge) and so does the shovel's bucket (same convention).
* :class:`FrontShovel`, three revolute joints (boom, stick, bucket) on a base that stays put during a
  dig and is placed between digs (§4.2): the planar chain of App. A1-1 without its waist (eqs. A1 11-19),
  with both elbow solutions tried.

The thesis gives no dimensions for either machine: every number is in ``configs/pile_loading_planar.yaml`` and is
assumed (sized for a pile about 2 m high; the shovel's bucket link 75 % of the loader's, as §4.2's
footnote). All functions are vectorized over leading dimensions.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from excavsim.errors import ConfigError

# (A1 21): the world frame w from frame 0 (x_w = -z_0, y_w = x_0, z_w = -y_0). The thesis' world y_w is our z.
W_T_0 = np.array([[0.0, 0.0, -1.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.0, -1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]])


def dh_transform(alpha_prev: float, a_prev: float, theta: float, d: float) -> np.ndarray:
    """The 4 x 4 transform of one modified Denavit-Hartenberg row: Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)."""
    ca, sa, ct, st = math.cos(alpha_prev), math.sin(alpha_prev), math.cos(theta), math.sin(theta)
    return np.array([[ct, -st, 0.0, a_prev],
                     [st * ca, ct * ca, -sa, -sa * d],
                     [st * sa, ct * sa, ca, ca * d],
                     [0.0, 0.0, 0.0, 1.0]])


def _check_limits(name: str, lo, hi) -> None:
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(np.asarray(lo) < np.asarray(hi))):
        raise ConfigError(f"{name}: joint limits must be finite with lower < upper; given {lo!r}, {hi!r}")


@dataclasses.dataclass(frozen=True, eq=False)
class FrontLoader:
    """The front loader of Table A1-3 (see the module docstring). Lengths [m], angles [rad].

    Attributes:
        l1: minus the shoulder's height above the ground (Table A1-3's a_1 = -l1; negative for a shoulder up).
        l2: the offset of the prismatic joint (the shoulder is at x = l2 - d1).
        l3: boom, shoulder to bucket pin; l4: bucket pin to tip; mu: the tip frame's turn from the bucket link.
        lower, upper: limits of (d1, theta2, theta3).
        wheel_front: how far the wheels reach ahead of the shoulder (the reachability constraint's
            "wheels at the foot of the pile", Fig. 31 (b)).
        floor: the bucket floor's length behind the tip (for the bucket-terrain collision, Fig. 31 (a)).
    """

    l1: float
    l2: float
    l3: float
    l4: float
    mu: float
    lower: np.ndarray
    upper: np.ndarray
    wheel_front: float
    floor: float

    kind = "loader"
    moves_base = True

    def __post_init__(self):
        for name in ("l3", "l4", "floor"):
            if not getattr(self, name) > 0:
                raise ConfigError(f"front loader: {name} must be > 0 m; given {getattr(self, name)!r}")
        _check_limits("front loader", self.lower, self.upper)

    def dh_rows(self, q) -> list[tuple[float, float, float, float]]:
        """Table A1-3's rows (alpha_{i-1}, a_{i-1}, theta_i, d_i) at joint values q = (d1, theta2, theta3)."""
        d1, t2, t3 = (float(v) for v in q)
        return [(0.0, 0.0, 0.0, d1 - self.l2), (math.pi / 2, -self.l1, math.pi + t2, 0.0),
                (0.0, self.l3, t3, 0.0), (0.0, self.l4, -self.mu, 0.0)]

    def forward_dh(self, q) -> np.ndarray:
        """The tip frame in the world, ``w_4T`` (4 x 4), as the product of (A1 21) and Table A1-3's rows."""
        t = W_T_0.copy()
        for row in self.dh_rows(q):
            t = t @ dh_transform(*row)
        return t

    def forward(self, q: np.ndarray) -> np.ndarray:
        """Tip poses (..., 3) (x, z, phi) of joint values (..., 3) (d1, theta2, theta3): the table's closed form."""
        q = np.asarray(q, dtype=float)
        d1, t2, t3 = q[..., 0], q[..., 1], q[..., 2]
        t23 = t2 + t3
        x = self.l2 - d1 + self.l3 * np.sin(t2) + self.l4 * np.sin(t23)
        z = -self.l1 - self.l3 * np.cos(t2) - self.l4 * np.cos(t23)
        phi = t23 - self.mu - math.pi / 2  # x_4 = (S_{23-mu}, -C_{23-mu})
        return np.stack([x, z, phi], axis=-1)

    def inverse(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Joint values (..., 3) and reachability (...,) of tip poses (..., 3): (A1 25-31) with the table's signs.

        theta23 = phi + mu + pi/2; the pin is l4 behind the tip along the bucket link, and its height fixes
        C2 = (-l1 - z_pin) / l3; of the two theta2 = +-acos, the first within the limits (smaller first); d1 from x.
        """
        p = np.asarray(poses, dtype=float)
        t23 = p[..., 2] + self.mu + math.pi / 2
        xp = p[..., 0] - self.l4 * np.sin(t23)
        zp = p[..., 1] + self.l4 * np.cos(t23)
        c2 = (-self.l1 - zp) / self.l3
        inside = np.abs(c2) <= 1.0
        base = np.arccos(np.clip(c2, -1.0, 1.0))
        best_q = np.full(p.shape, np.nan)
        best_ok = np.zeros(p.shape[:-1], bool)
        for t2 in (base, -base):
            t3 = _wrap_near(t23 - t2, 0.5 * (self.lower[2] + self.upper[2]))
            d1 = self.l2 + self.l3 * np.sin(t2) - xp
            q = np.stack([d1, t2, t3], axis=-1)
            ok = inside & np.all((q >= self.lower) & (q <= self.upper), axis=-1) & ~best_ok
            best_q = np.where(ok[..., None], q, best_q)
            best_ok |= ok
        return best_q, best_ok

    def points(self, q: np.ndarray) -> np.ndarray:
        """The skeleton (..., 4, 2): the base at the ground below the shoulder, the shoulder, the pin, the tip."""
        q = np.asarray(q, dtype=float)
        d1, t2 = q[..., 0], q[..., 1]
        sx = self.l2 - d1
        sz = np.full_like(sx, -self.l1)
        px = sx + self.l3 * np.sin(t2)
        pz = sz - self.l3 * np.cos(t2)
        tip = self.forward(q)
        return np.stack([np.stack([sx, np.zeros_like(sx)], -1), np.stack([sx, sz], -1), np.stack([px, pz], -1),
                         tip[..., :2]], axis=-2)

    def wheels_x(self, q: np.ndarray) -> np.ndarray:
        """(...,) the x of the wheels' front at joint values (..., 3)."""
        return self.l2 - np.asarray(q, dtype=float)[..., 0] + self.wheel_front


@dataclasses.dataclass(frozen=True, eq=False)
class FrontShovel:
    """The front shovel: boom, stick and bucket, three revolute joints on a base placed between digs (§4.2).

    Attributes:
        shoulder_height: the boom's pivot above the ground; shoulder_ahead: its x ahead of the base's rear.
        l1, l2: boom and stick lengths; l3: bucket pin to tip; mu: the floor's turn from the bucket link.
        lower, upper: limits of (theta1, theta2, theta3), each link's angle relative to the previous one
            (theta1 from +x), counter-clockwise positive.
        track_front: how far the tracks reach ahead of the pivot (where the base is put, next to the foot).
        floor: the bucket floor's length behind the tip (the bucket-terrain collision, Fig. 33 (a)).
    """

    shoulder_height: float
    l1: float
    l2: float
    l3: float
    mu: float
    lower: np.ndarray
    upper: np.ndarray
    track_front: float
    floor: float

    kind = "shovel"
    moves_base = False

    def __post_init__(self):
        for name in ("l1", "l2", "l3", "floor"):
            if not getattr(self, name) > 0:
                raise ConfigError(f"front shovel: {name} must be > 0 m; given {getattr(self, name)!r}")
        _check_limits("front shovel", self.lower, self.upper)

    def forward(self, q: np.ndarray, base_x: float | np.ndarray = 0.0) -> np.ndarray:
        """Tip poses (..., 3) of joint angles (..., 3), the pivot at (``base_x``, ``shoulder_height``)."""
        q = np.asarray(q, dtype=float)
        a1 = q[..., 0]
        a12 = a1 + q[..., 1]
        a123 = a12 + q[..., 2]
        x = base_x + self.l1 * np.cos(a1) + self.l2 * np.cos(a12) + self.l3 * np.cos(a123)
        z = self.shoulder_height + self.l1 * np.sin(a1) + self.l2 * np.sin(a12) + self.l3 * np.sin(a123)
        return np.stack([x, z, a123 - self.mu], axis=-1)

    def inverse(self, poses: np.ndarray, base_x: float | np.ndarray = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Joint angles (..., 3) and reachability (...,): the planar chain's IK (eqs. A1 11-19), both elbows tried.

        The wrist pin is l3 behind the tip along the bucket link (phi + mu); the boom and stick reach it
        by the law of cosines (A1 13), theta1 by (A1 18) and theta3 by (A1 19). The elbow-up solution
        (stick turned down from the boom, theta2 < 0) is taken where it is within the limits, else the other.
        """
        p = np.asarray(poses, dtype=float)
        a123 = p[..., 2] + self.mu
        wx = p[..., 0] - self.l3 * np.cos(a123) - base_x
        wz = p[..., 1] - self.l3 * np.sin(a123) - self.shoulder_height
        c2 = (wx ** 2 + wz ** 2 - self.l1 ** 2 - self.l2 ** 2) / (2 * self.l1 * self.l2)
        inside = np.abs(c2) <= 1.0
        s2 = np.sqrt(np.clip(1.0 - c2 ** 2, 0.0, 1.0))
        best_q = np.full(p.shape, np.nan)
        best_ok = np.zeros(p.shape[:-1], bool)
        for sign in (-1.0, 1.0):
            t2 = np.arctan2(sign * s2, c2)
            t1 = np.arctan2(wz, wx) - np.arctan2(self.l2 * np.sin(t2), self.l1 + self.l2 * np.cos(t2))
            t3 = _wrap_near(a123 - t1 - t2, 0.5 * (self.lower[2] + self.upper[2]))
            q = np.stack([_wrap_near(t1, 0.5 * (self.lower[0] + self.upper[0])), t2, t3], axis=-1)
            ok = inside & np.all((q >= self.lower) & (q <= self.upper), axis=-1) & ~best_ok
            best_q = np.where(ok[..., None], q, best_q)
            best_ok |= ok
        return best_q, best_ok

    def points(self, q: np.ndarray, base_x: float | np.ndarray = 0.0) -> np.ndarray:
        """The skeleton (..., 5, 2): the base at the ground, the pivot, the stick's joint, the pin, the tip."""
        q = np.asarray(q, dtype=float)
        a1 = q[..., 0]
        a12 = a1 + q[..., 1]
        bx = np.broadcast_to(np.asarray(base_x, dtype=float), a1.shape)
        p0 = np.stack([bx, np.zeros_like(a1)], -1)
        p1 = np.stack([bx, np.full_like(a1, self.shoulder_height)], -1)
        p2 = p1 + self.l1 * np.stack([np.cos(a1), np.sin(a1)], -1)
        p3 = p2 + self.l2 * np.stack([np.cos(a12), np.sin(a12)], -1)
        tip = self.forward(q, base_x)[..., :2]
        return np.stack([p0, p1, p2, p3, tip], axis=-2)


def _wrap_near(a: np.ndarray, centre: float) -> np.ndarray:
    """Angles ``a`` moved by whole turns into [centre - pi, centre + pi)."""
    return (np.asarray(a) - centre + math.pi) % (2 * math.pi) - math.pi + centre


Machine = FrontLoader | FrontShovel
