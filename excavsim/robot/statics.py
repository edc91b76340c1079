"""Static joint torques of the planar digging chain (Singh 1995 §5.3, App. 2).

The torque a joint must deliver to hold the arm still against the soil is (eq. 28)

    τ = τ_grav − J^T F

with τ_grav from the weight of the links (eq. 31 / A2-4: τ_i = g Σ_{n≥i} l_{i,n} m_n cos ψ_{i,n}, the
horizontal moment arm of each downstream centre of mass) and J^T F the generalized force that a
wrench F applied at the bucket tip exerts on the joints (eqs. 29-30 / A2-5). The analysis is static:
no accelerations of soil or links are considered (App. 2). Sign convention: ``F`` is the force the
soil exerts on the bucket; torques are in joint coordinates (``qpos`` sign), N m.
"""

from __future__ import annotations

import numpy as np

from excavsim.robot.kinematics import PlanarArm, rotate2


def tip_wrench_torques(arm: PlanarArm, q: np.ndarray, wrench: np.ndarray) -> np.ndarray:
    """Generalized force ``J^T F`` that a planar wrench at the bucket tip exerts on the joints (eq. 29).

    Args:
        arm: the planar chain.
        q: (..., 3) planar joint angles [rad].
        wrench: (..., 3) force on the bucket at the tip in the arm plane, ``(F_x, F_z, M)``: F_x
            radial (away from the waist axis), F_z up [N], M the moment about the tip,
            counter-clockwise in (x, z) [N m]. Broadcast against ``q``.

    Returns:
        (..., 3) joint torques [N m], as MuJoCo's ``qfrc`` would show for the same applied wrench.
    """
    jac = arm.jacobian(np.asarray(q, dtype=float))
    return np.einsum("...ij,...i->...j", jac, np.asarray(wrench, dtype=float))


def tip_force_in_plane(force_tip_frame: np.ndarray, pitch: np.ndarray) -> np.ndarray:
    """Rotate a tip-frame force (F_x along the blade, F_z normal into the bucket) into the arm plane.

    This is the planar frame Jacobian of eq. 30 / A2-7 for a force applied at the tip itself.

    Args:
        force_tip_frame: (..., 2) force (F_x, F_z) in the tip frame [N].
        pitch: (...) bucket pitch ρ [rad].

    Returns:
        (..., 2) force (F_x, F_z) in the arm plane [N].
    """
    # The tip frame's x axis is the blade, at counter-clockwise angle π + ρ in (x, z). Its y axis is
    # the plane's -y, so its z axis (into the bucket) lies 90° *clockwise* of x: (-sin ρ, cos ρ).
    f = np.asarray(force_tip_frame, dtype=float)
    return rotate2(np.pi + np.asarray(pitch, dtype=float), np.stack([f[..., 0], -f[..., 1]], axis=-1))


def gravity_torques(arm: PlanarArm, q: np.ndarray, *, payload_kg: float | np.ndarray = 0.0,
                    payload_com_tip: np.ndarray | None = None) -> np.ndarray:
    """Torques that hold the links (and an optional payload) against gravity (eq. 31, A2-4).

    Args:
        arm: the planar chain.
        q: (..., 3) planar joint angles [rad].
        payload_kg: soil carried in the bucket [kg], broadcast against ``q[..., 0]``.
        payload_com_tip: (2,) payload centre of mass in the tip frame (x along the blade, z into
            the bucket) [m]; at the tip when None.

    Returns:
        (..., 3) holding torques [N m]; equal to MuJoCo's ``qfrc_bias`` at rest.
    """
    q = np.asarray(q, dtype=float)
    pts = arm.joint_points(q)  # (..., 4, 2)
    th = arm._link_angles(q)
    coms = np.stack([pts[..., k, :] + rotate2(th[..., k], arm.link_coms[k]) for k in range(3)], axis=-2)
    # Holding torque about joint i (CCW): g Σ_{n≥i} m_n (x_com_n − x_joint_i)  (eq. 31).
    dx = coms[..., None, :, 0] - pts[..., :3, None, 0]  # (..., joint i, link n)
    upper = np.triu(np.ones((3, 3)))  # n ≥ i
    tau = arm.gravity * np.einsum("...in,n,in->...i", dx, arm.link_masses, upper)
    payload = np.asarray(payload_kg, dtype=float)
    if np.any(payload != 0):
        off = np.zeros(2) if payload_com_tip is None else np.asarray(payload_com_tip, dtype=float)
        pitch = arm.forward(q)[..., 2]
        p_load = pts[..., 3, :] + tip_force_in_plane(off, pitch)
        tau = tau + arm.gravity * payload[..., None] * (p_load[..., None, 0] - pts[..., :3, 0])
    return tau * arm.joint_signs


def static_joint_torques(arm: PlanarArm, q: np.ndarray, wrench: np.ndarray, **gravity_kwargs) -> np.ndarray:
    """Actuator torques that hold the arm still against a tip wrench and gravity (eq. 28).

    Args:
        arm: the planar chain.
        q: (..., 3) planar joint angles [rad].
        wrench: (..., 3) wrench of the soil on the bucket at the tip, ``(F_x, F_z, M)`` in the arm
            plane (see :func:`tip_wrench_torques`).
        **gravity_kwargs: passed to :func:`gravity_torques` (payload).

    Returns:
        (..., 3) torques [N m]; compare their magnitudes with the joints' relief limits.
    """
    return gravity_torques(arm, q, **gravity_kwargs) - tip_wrench_torques(arm, q, wrench)
