"""The hydraulic arm's compliance (Singh 1995 §7.1.3): the oscillation on touch-down and the joints' give.

The nominal servos of ``configs/robot.yaml`` are stiff and over-damped (damping ratios 0.9-1.9 at
the home pose): a commanded move settles without ringing and a joint yields under load only by the
servo's own lag, which the encoders see. The testbed did neither. "Under certain configurations of
the joints, the end-effector overshoots the destination and oscillates briefly before settling.
Force readings must be taken after this oscillation has died down" (§7.1.3, Fig. 104), and "under
great resistive forces some of the joints comply. In effect, the end-effector is not where it is
expected to be, but there is no way of detecting this condition" (§7.1.3). Two truth terms of
``configs/scene.yaml`` (``truth.arm_damping_ratio``, ``truth.arm_give_share``) give the world's
planar joints (shoulder, elbow, wrist pitch) those two behaviours; both are off by default.

**Give under load** (``arm_give_share`` = c). Each planar joint is a servo of stiffness ``kp``
(robot.yaml) driving the link through a compliant transmission (the oil column and the linkage)
of stiffness ``k_t = kp / c``, with the joint's encoder on the actuator's side of it. The torque
``tau`` through the series pair is ``tau = kp (sp - theta_a)``, ``theta_a - q = tau / k_t``, so the
link sees the servo of stiffness ``k_eff = kp / (1 + c)`` (``tau = k_eff (sp - q)`` at rest) and the
encoder reads ``theta_a = q + c tau / kp``: of the link's static give ``tau / k_eff`` under a load,
the encoder sees the servo's part ``tau / kp`` and misses the transmission's ``c tau / kp``.
Simplifications (assumed): the transmission has no mass; the servo's damping acts on the link's
velocity; ``tau`` is MuJoCo's actuator force (clipped at the relief torque). c = 1 is assumed (no
number in the thesis): the tip gives about 8 mm per kN unseen in the digging poses.

**Contact oscillation** (``arm_damping_ratio`` = zeta). Each planar joint's servo damping ``kv`` is
set so that, taken alone with the other joints locked, the joint at the home keyframe is a
second-order system of damping ratio zeta: ``kv + b = 2 zeta sqrt(k_eff I)`` with ``b`` the joint's
own damping and ``I`` its diagonal inertia entry (armature included) at home. In other poses the
inertia differs and so does the damping ratio ("under certain configurations of the joints"). A
commanded move that stops, or the bucket meeting the soil, then rings at the arm's natural
frequencies (5-9 Hz here) and the wrist F/T reads the bucket's inertial force ``m a`` over the
soil's: the overshoot of Fig. 104. zeta = 0.1 is assumed: valve-controlled hydraulic actuators are
lightly damped (their hydraulic damping ratio is small unless leakage or a damping orifice is
added), and 0.1 makes a move ring for a few cycles ("oscillates briefly before settling").
Simplification: a linear damper; the real valve's flow-pressure curve makes the damping depend on
the load.

The world applies both to the compiled model (:func:`apply_arm_truth`) and reads the encoders
through :func:`encoder_angles`; the robot's mind keeps robot.yaml's numbers.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from excavsim import constants


@dataclasses.dataclass(frozen=True)
class ArmTruth:
    """What :func:`apply_arm_truth` set, per joint in ``constants.JOINTS`` order.

    Attributes:
        kp: the servo stiffness the link sees now, ``k_eff`` [N m/rad].
        kv: the servo damping now [N m s/rad].
        give: ``c / kp`` of robot.yaml: the encoder reads ``q + give * tau`` [rad/(N m)]; 0 off.
        inertia: the diagonal inertia at the home keyframe used for ``kv`` [kg m^2].
    """

    kp: np.ndarray
    kv: np.ndarray
    give: np.ndarray
    inertia: np.ndarray

    @property
    def gives(self) -> bool:
        """Whether any joint's encoder misses part of its give."""
        return bool(np.any(self.give != 0.0))


def apply_arm_truth(model: mujoco.MjModel, data: mujoco.MjData, actuators: np.ndarray, dofs: np.ndarray, *,
                    damping_ratio: float | None, give_share: float) -> ArmTruth:
    """Write the planar joints' compliance into ``model`` (in place; see the module docstring).

    Args:
        model, data: the compiled scene, ``data`` at the home keyframe (its inertia sets ``kv``).
        actuators, dofs: (6,) the servos' actuator ids and the joints' dof addresses, in
            ``constants.JOINTS`` order.
        damping_ratio: zeta of each planar joint at home; None keeps robot.yaml's ``kv``.
        give_share: c, the transmission's compliance as a share of the servo's; 0 is rigid.

    Returns:
        The numbers set.
    """
    mujoco.mj_forward(model, data)
    full = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, full)
    inertia = np.diag(full)[dofs].copy()
    kp = model.actuator_gainprm[actuators, 0].copy()
    kv = -model.actuator_biasprm[actuators, 2].copy()
    give = np.zeros(len(actuators))
    planar = [constants.JOINTS.index(j) for j in constants.PLANAR_JOINTS]
    for k in planar:
        a = int(actuators[k])
        give[k] = give_share / kp[k]
        kp[k] = kp[k] / (1.0 + give_share)
        if damping_ratio is not None:
            kv[k] = max(0.0, 2.0 * damping_ratio * np.sqrt(kp[k] * inertia[k]) - model.dof_damping[dofs[k]])
        model.actuator_gainprm[a, 0] = kp[k]
        model.actuator_biasprm[a, 1] = -kp[k]
        model.actuator_biasprm[a, 2] = -kv[k]
    return ArmTruth(kp, kv, give, inertia)


def encoder_angles(qpos: np.ndarray, actuator_force: np.ndarray, give: np.ndarray) -> np.ndarray:
    """The joint encoders (6,) [rad]: the links' angles ``qpos`` plus the transmission's stretch
    ``give * tau`` under the actuator torques ``actuator_force`` (see the module docstring)."""
    return qpos + give * actuator_force


def mode_table(model: mujoco.MjModel, data: mujoco.MjData, actuators: np.ndarray, dofs: np.ndarray, *,
               gain_per_s: float = 0.0, give: np.ndarray | None = None) -> list[tuple[float, float]]:
    """The linearized arm's oscillating modes at ``data``'s pose: (damped frequency [Hz], damping ratio),
    slowest first.

    The hand derivation the tests hold the simulated ring-down against: ``M q'' + C q' = tau``,
    ``tau = K (sp - q) - C_v q'`` with ``M`` the joints' inertia matrix (armature included),
    ``K = diag(kp)``, ``C = diag(b)`` the joints' own damping and ``C_v = diag(kv)`` the servos'; with
    ``gain_per_s`` g the set-points follow the world's servo law towards a fixed target
    (``sp' = g (target - q_enc)``, :func:`~excavsim.robot.servo.setpoint_rates` below its flow limit),
    the encoders reading ``q_enc = q + give tau`` (:func:`encoder_angles`); with g = 0 the set-points
    are held. Gravity's stiffness is left out (under 1 % of the servos' here), and so are the torque
    and flow limits.
    """
    mujoco.mj_forward(model, data)
    full = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, full)
    n = len(dofs)
    m = full[np.ix_(dofs, dofs)]
    k = np.diag(model.actuator_gainprm[actuators, 0])
    cv = np.diag(-model.actuator_biasprm[actuators, 2])
    c = cv + np.diag(model.dof_damping[dofs])
    g = np.diag(np.zeros(n) if give is None else give)
    minv = np.linalg.inv(m)
    z, eye = np.zeros((n, n)), np.eye(n)
    # states (q, q', sp); tau = K sp - K q - Cv q'
    a = np.block([[z, eye, z], [-minv @ k, -minv @ c, minv @ k],
                  [-gain_per_s * (eye - g @ k), gain_per_s * g @ cv, -gain_per_s * g @ k]])
    lam = np.linalg.eigvals(a)
    lam = lam[lam.imag > 1e-9]
    return sorted((float(x.imag / (2 * np.pi)), float(-x.real / abs(x))) for x in lam)
