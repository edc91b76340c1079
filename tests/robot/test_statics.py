"""Static joint torques against MuJoCo: J^T F from xfrc_applied, gravity from qfrc_bias at rest."""

from __future__ import annotations

import mujoco
import numpy as np

from excavsim import constants
from excavsim.robot.statics import (
    gravity_torques,
    static_joint_torques,
    tip_force_in_plane,
    tip_wrench_torques,
)

PLANAR = slice(1, 4)  # shoulder, elbow, wrist pitch in qpos/qvel order


def _at_rest(model, data, q4):
    data.qpos[:] = 0.0
    data.qpos[:4] = q4
    data.qvel[:] = 0.0
    data.act[:] = data.qpos  # set-points at the joints: no servo torque
    data.ctrl[:] = 0.0
    data.xfrc_applied[:] = 0.0
    mujoco.mj_forward(model, data)


def _plane_axes(waist):
    radial = np.array([np.cos(waist), np.sin(waist), 0.0])
    minus_y = np.array([np.sin(waist), -np.cos(waist), 0.0])
    return radial, minus_y


def test_tip_wrench_torques_equal_mujoco_generalized_force_from_xfrc_applied(mj_model, arm, rng):
    data = mujoco.MjData(mj_model)
    bid = mj_model.body(constants.BUCKET_BODY).id
    sid = mj_model.site(constants.BUCKET_TIP_SITE).id
    ids = [mj_model.joint(j).id for j in constants.JOINTS[:4]]
    for _ in range(200):
        q4 = rng.uniform(mj_model.jnt_range[ids, 0], mj_model.jnt_range[ids, 1])
        wrench = rng.normal(0.0, [800.0, 800.0, 200.0])  # (F_x, F_z) N, M N m
        _at_rest(mj_model, data, q4)
        without = data.qfrc_smooth.copy()
        radial, minus_y = _plane_axes(q4[0])
        force = wrench[0] * radial + wrench[1] * np.array([0.0, 0.0, 1.0])
        # xfrc_applied acts at the body's centre of mass: move the tip force there with its moment.
        data.xfrc_applied[bid, :3] = force
        data.xfrc_applied[bid, 3:] = np.cross(data.site_xpos[sid] - data.xipos[bid], force) + wrench[2] * minus_y
        mujoco.mj_forward(mj_model, data)
        generalized = data.qfrc_smooth - without
        np.testing.assert_allclose(tip_wrench_torques(arm, q4[1:], wrench), generalized[PLANAR], atol=1e-8)


def test_gravity_torques_equal_qfrc_bias_at_rest(mj_model, arm, rng):
    data = mujoco.MjData(mj_model)
    ids = [mj_model.joint(j).id for j in constants.JOINTS[:4]]
    q = rng.uniform(mj_model.jnt_range[ids, 0], mj_model.jnt_range[ids, 1], (300, 4))
    ours = gravity_torques(arm, q[:, 1:])
    for k in range(len(q)):
        _at_rest(mj_model, data, q[k])
        np.testing.assert_allclose(ours[k], data.qfrc_bias[PLANAR], atol=1e-8)
        # Waist, wrist yaw and roll carry no gravity torque in the planar configuration.
        np.testing.assert_allclose(data.qfrc_bias[[0, 4, 5]], 0.0, atol=1e-8)


def test_gravity_torque_at_a_stretched_arm_by_hand(arm):
    # Arm horizontal (all angles zero): each holding torque is g times the sum of mass x horizontal
    # distance to the joint (eq. 31 with cos ψ = 1 for links along the horizontal).
    g = arm.gravity
    tau = gravity_torques(arm, np.zeros(3))
    joints_x = arm.shoulder_xz[0] + np.array([0.0, arm.links[0, 0], arm.links[0, 0] + arm.links[1, 0]])
    coms_x = joints_x + arm.link_coms[:, 0]
    by_hand = [g * sum(arm.link_masses[n] * (coms_x[n] - joints_x[i]) for n in range(i, 3)) for i in range(3)]
    np.testing.assert_allclose(tau, by_hand, rtol=1e-12)


def test_payload_gravity_equals_mujoco_with_the_mass_added(mj_model, arm, rng):
    model = mujoco.MjModel.from_xml_path(str(constants.SCENE_XML))
    bid = model.body(constants.BUCKET_BODY).id
    sid = model.site(constants.BUCKET_TIP_SITE).id
    payload, com_tip = 40.0, np.array([-0.15, 0.0, 0.12])  # 40 kg of sand inside the bucket
    site_rot = np.array([[0, 0, -1], [0, -1, 0], [-1, 0, 0]], dtype=float)  # tip-frame axes in the body
    p_body = model.site_pos[sid] + site_rot @ com_tip
    m0, c0 = model.body_mass[bid], model.body_ipos[bid].copy()
    model.body_mass[bid] = m0 + payload
    model.body_ipos[bid] = (m0 * c0 + payload * p_body) / (m0 + payload)
    data = mujoco.MjData(model)
    q = rng.uniform(arm.lower, arm.upper, (50, 3))
    ours = gravity_torques(arm, q, payload_kg=payload, payload_com_tip=com_tip[[0, 2]])
    for k in range(len(q)):
        _at_rest(model, data, np.r_[0.0, q[k]])
        np.testing.assert_allclose(ours[k], data.qfrc_bias[PLANAR], atol=1e-7)


def test_tip_frame_force_rotation_matches_the_site_frame(mj_model, arm, rng):
    data = mujoco.MjData(mj_model)
    for _ in range(50):
        q = rng.uniform(arm.lower, arm.upper)
        _at_rest(mj_model, data, np.r_[0.0, q])
        mat = data.site(constants.BUCKET_TIP_SITE).xmat.reshape(3, 3)
        f_tip = rng.normal(size=2) * 300  # (F_x along the blade, F_z into the bucket)
        world = mat @ np.array([f_tip[0], 0.0, f_tip[1]])
        ours = tip_force_in_plane(f_tip, arm.forward(q)[2])
        np.testing.assert_allclose(ours, world[[0, 2]], atol=1e-9)


def test_static_joint_torques_combine_gravity_and_soil(arm, rng):
    q = rng.uniform(arm.lower, arm.upper, (10, 3))
    w = rng.normal(size=(10, 3)) * 500
    np.testing.assert_allclose(static_joint_torques(arm, q, w),
                               gravity_torques(arm, q) - tip_wrench_torques(arm, q, w))


def test_a_resisting_force_at_the_tip_loads_the_wrist_by_its_moment_arm(arm):
    # Hand check of J^T F for the wrist: a force F on the tip produces r x F about the wrist axis.
    q = np.array([0.6, -1.6, -0.5])
    pts = arm.joint_points(q)
    r = pts[3] - pts[2]
    force = np.array([600.0, -200.0])
    by_hand = r[0] * force[1] - r[1] * force[0]
    np.testing.assert_allclose(tip_wrench_torques(arm, q, np.r_[force, 0.0])[2], by_hand, rtol=1e-12)
