"""Compiled inverse kinematics and static joint torques for many poses at once (numba).

The planner evaluates IK and ``tau = tau_grav - J^T F`` (eq. 28) at hundreds of thousands of
trajectory samples per plan. These scalar loops compute exactly what
:meth:`~excavsim.robot.kinematics.PlanarArm.inverse` and
:func:`~excavsim.robot.statics.static_joint_torques` compute with numpy broadcasting (a test holds
them equal, and those are tested against MuJoCo), an order of magnitude faster.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from excavsim.robot.kinematics import PlanarArm


def arm_params(arm: PlanarArm) -> np.ndarray:
    """The chain's numbers packed for :func:`ik_torques` (one float64 vector)."""
    return np.concatenate([
        arm.shoulder_xz, arm.links.ravel(), arm.joint_signs, [arm.blade_angle0], arm.lower, arm.upper,
        arm.link_masses, arm.link_coms.ravel(), [arm.gravity],
    ]).astype(np.float64)


@numba.njit(cache=True, inline="always")
def _wrap(a):
    return (a + math.pi) % (2.0 * math.pi) - math.pi


@numba.njit(cache=True)
def ik_torques(p, poses, wrench, payload, load_tip, want_torques, q_out, ok_out, tau_out):
    """Elbow-up IK of ``poses`` (n, 3) and, where reachable and ``want_torques``, the static torques.

    Args:
        p: :func:`arm_params`.
        poses: (n, 3) tip poses (x, z, pitch).
        wrench: (n, 3) soil wrench on the bucket at the tip (F_x, F_z, M).
        payload: (n,) load in the bucket [kg]; load_tip: (2,) its centre in the tip frame.
        q_out, ok_out, tau_out: (n, 3), (n,), (n, 3) outputs (NaN where unreachable).
    """
    sx, sz = p[0], p[1]
    lx = p[2:8:2]
    lz = p[3:8:2]
    sg = p[8:11]
    blade0 = p[11]
    lo = p[12:15]
    hi = p[15:18]
    mass = p[18:21]
    cx = p[21:27:2]
    cz = p[22:27:2]
    g = p[27]
    l1 = math.hypot(lx[0], lz[0])
    l2 = math.hypot(lx[1], lz[1])
    b0 = math.atan2(lz[0], lx[0])
    b1 = math.atan2(lz[1], lx[1])
    for i in range(poses.shape[0]):
        x, z, pitch = poses[i, 0], poses[i, 1], poses[i, 2]
        th3 = pitch + math.pi - blade0
        c3, s3 = math.cos(th3), math.sin(th3)
        wx = x - (c3 * lx[2] - s3 * lz[2])
        wz = z - (s3 * lx[2] + c3 * lz[2])
        dx, dz = wx - sx, wz - sz
        cg = (dx * dx + dz * dz - l1 * l1 - l2 * l2) / (2.0 * l1 * l2)
        ok = abs(cg) <= 1.0 and math.isfinite(x) and math.isfinite(z) and math.isfinite(pitch)
        gam = -math.acos(min(max(cg, -1.0), 1.0))
        a1 = math.atan2(dz, dx) - math.atan2(l2 * math.sin(gam), l1 + l2 * math.cos(gam))
        t1 = a1 - b0
        t2 = a1 + gam - b1 - t1
        t3 = th3 - t1 - t2
        q0 = _wrap(t1 * sg[0])
        q1 = _wrap(t2 * sg[1])
        q2 = _wrap(t3 * sg[2])
        ok = ok and lo[0] - 1e-12 <= q0 <= hi[0] + 1e-12 and lo[1] - 1e-12 <= q1 <= hi[1] + 1e-12 \
            and lo[2] - 1e-12 <= q2 <= hi[2] + 1e-12
        ok_out[i] = ok
        if not ok:
            for j in range(3):
                q_out[i, j] = np.nan
                tau_out[i, j] = np.nan
            continue
        q_out[i, 0] = q0
        q_out[i, 1] = q1
        q_out[i, 2] = q2
        if not want_torques:
            continue
        # link angles and joint points from the wrapped joint angles (as PlanarArm does)
        h0 = q0 * sg[0]
        h1 = h0 + q1 * sg[1]
        h2 = h1 + q2 * sg[2]
        c0, s0 = math.cos(h0), math.sin(h0)
        c1, s1 = math.cos(h1), math.sin(h1)
        c2, s2 = math.cos(h2), math.sin(h2)
        p1x, p1z = sx + c0 * lx[0] - s0 * lz[0], sz + s0 * lx[0] + c0 * lz[0]
        p2x, p2z = p1x + c1 * lx[1] - s1 * lz[1], p1z + s1 * lx[1] + c1 * lz[1]
        p3x, p3z = p2x + c2 * lx[2] - s2 * lz[2], p2z + s2 * lx[2] + c2 * lz[2]
        m0 = mass[0] * (sx + c0 * cx[0] - s0 * cz[0])
        m1 = mass[1] * (p1x + c1 * cx[1] - s1 * cz[1])
        m2 = mass[2] * (p2x + c2 * cx[2] - s2 * cz[2])
        a = math.pi + _wrap(blade0 + h2 - math.pi)
        load_x = p3x + math.cos(a) * load_tip[0] + math.sin(a) * load_tip[1]  # rot(pi + pitch) (x, -z)
        w = payload[i]
        fx, fz, mom = wrench[i, 0], wrench[i, 1], wrench[i, 2]
        # joint j holds links n >= j and the payload: g sum m_n (x_com_n - x_j) (eq. 31)
        g2 = m2 + w * load_x - (mass[2] + w) * p2x
        g1 = m1 + m2 + w * load_x - (mass[1] + mass[2] + w) * p1x
        g0 = m0 + m1 + m2 + w * load_x - (mass[0] + mass[1] + mass[2] + w) * sx
        tau_out[i, 0] = sg[0] * (g * g0 - (-(p3z - sz) * fx + (p3x - sx) * fz + mom))
        tau_out[i, 1] = sg[1] * (g * g1 - (-(p3z - p1z) * fx + (p3x - p1x) * fz + mom))
        tau_out[i, 2] = sg[2] * (g * g2 - (-(p3z - p2z) * fx + (p3x - p2x) * fz + mom))
