"""Planar kinematics against MuJoCo: forward kinematics, inverse kinematics, Jacobian."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from dm_control import mjcf

from excavsim import constants
from excavsim.errors import ModelError
from excavsim.robot.extract import arm_from_model
from excavsim.robot.kinematics import wrap_angle


def _random_arm_q(model: mujoco.MjModel, rng, n: int) -> np.ndarray:
    """(n, 4) waist, shoulder, elbow, wrist pitch uniformly within the joint ranges."""
    ids = [model.joint(j).id for j in constants.JOINTS[:4]]
    return rng.uniform(model.jnt_range[ids, 0], model.jnt_range[ids, 1], (n, 4))


def _mujoco_tip(model, data, q4):
    data.qpos[:] = 0.0
    data.qpos[:4] = q4
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)  # mj_jacSite needs the com-based quantities
    site = data.site(constants.BUCKET_TIP_SITE)
    return site.xpos.copy(), site.xmat.reshape(3, 3).copy()


def test_forward_kinematics_equals_mujoco_site_pose(mj_model, arm, rng):
    data = mujoco.MjData(mj_model)
    q = _random_arm_q(mj_model, rng, 1000)
    ours_pos = arm.tip_world(q)
    ours_pitch = arm.forward(q[:, 1:])[:, 2]
    for k in range(len(q)):
        pos, mat = _mujoco_tip(mj_model, data, q[k])
        np.testing.assert_allclose(ours_pos[k], pos, atol=1e-9, rtol=0)
        # Pitch from MuJoCo's site frame: the blade (x axis) is at angle π + pitch in the arm plane.
        radial = np.array([np.cos(q[k, 0]), np.sin(q[k, 0]), 0.0])
        blade = mat[:, 0]
        pitch_mj = np.arctan2(-blade[2], -blade @ radial)
        assert abs(wrap_angle(ours_pitch[k] - pitch_mj)) < 1e-9
        # The tip frame stays in the arm plane when yaw and roll are zero.
        assert abs(blade @ np.array([-np.sin(q[k, 0]), np.cos(q[k, 0]), 0.0])) < 1e-9


def test_forward_kinematics_is_vectorized_over_leading_dimensions(arm, rng):
    q = rng.uniform(arm.lower, arm.upper, (4, 5, 3))
    out = arm.forward(q)
    assert out.shape == (4, 5, 3)
    np.testing.assert_allclose(out[2, 3], arm.forward(q[2, 3]))


def test_inverse_of_forward_returns_the_elbow_up_configuration(arm, rng):
    q = rng.uniform(arm.lower, arm.upper, (20000, 3))
    q[:, 1] = rng.uniform(arm.lower[1], -0.05, len(q))  # elbow up: forearm bent clockwise
    q_back, ok = arm.inverse(arm.forward(q))
    assert ok.all()
    np.testing.assert_allclose(q_back, q, atol=1e-6)
    assert np.all((q_back >= arm.lower) & (q_back <= arm.upper))


def test_forward_of_inverse_reaches_the_pose(arm, rng):
    n = 20000
    poses = np.stack([rng.uniform(0.5, 3.2, n), rng.uniform(-0.2, 2.2, n),
                      np.radians(rng.uniform(-90, 90, n))], axis=-1)
    q, ok = arm.inverse(poses)
    assert 0.2 < ok.mean() < 0.9  # the workspace is real but limited (Fig. 95)
    np.testing.assert_allclose(arm.forward(q[ok])[:, :2], poses[ok, :2], atol=1e-9)
    assert np.all(np.abs(wrap_angle(arm.forward(q[ok])[:, 2] - poses[ok, 2])) < 1e-9)
    assert np.all(np.isnan(q[~ok]))


def test_unreachable_poses_are_reported(arm):
    too_far = [5.0, 1.0, 0.3]
    too_close_below = [0.3, -1.0, 0.0]
    nan_pose = [np.nan, 1.0, 0.0]
    q, ok = arm.inverse(np.array([too_far, too_close_below, nan_pose]))
    assert not ok.any()
    assert np.isnan(q).all()


def test_poses_needing_a_joint_beyond_its_limit_are_unreachable(arm):
    # Within the two-link annulus, but only with the wrist beyond its range.
    q = np.array([0.5, -1.2, 0.0])
    pose = arm.forward(q)
    _, ok = arm.inverse(pose)
    assert ok
    shifted = pose + np.array([0.0, 0.0, arm.upper[2] + 0.2])  # same wrist point, q_wrist = upper + 0.2
    q_s, ok_s = arm.inverse(shifted)
    assert not ok_s, q_s


def test_jacobian_equals_mj_jac_site(mj_model, arm, rng):
    data = mujoco.MjData(mj_model)
    sid = mj_model.site(constants.BUCKET_TIP_SITE).id
    dof = [mj_model.joint(j).dofadr[0] for j in constants.PLANAR_JOINTS]
    q = _random_arm_q(mj_model, rng, 200)
    ours = arm.jacobian(q[:, 1:])
    for k in range(len(q)):
        _mujoco_tip(mj_model, data, q[k])
        jacp, jacr = np.zeros((3, mj_model.nv)), np.zeros((3, mj_model.nv))
        mujoco.mj_jacSite(mj_model, data, jacp, jacr, sid)
        radial = np.array([np.cos(q[k, 0]), np.sin(q[k, 0]), 0.0])
        minus_y = np.array([np.sin(q[k, 0]), -np.cos(q[k, 0]), 0.0])  # CCW in (x, z) is about -y
        ref = np.vstack([radial @ jacp[:, dof], jacp[2, dof], minus_y @ jacr[:, dof]])
        np.testing.assert_allclose(ours[k], ref, atol=1e-12)


def test_jacobian_matches_finite_differences_of_forward(arm, rng):
    q = rng.uniform(arm.lower, arm.upper, (50, 3))
    eps = 1e-6
    fd = np.stack([(arm.forward(q + eps * e) - arm.forward(q - eps * e)) / (2 * eps) for e in np.eye(3)], axis=-1)
    np.testing.assert_allclose(arm.jacobian(q), fd, atol=1e-6)


def test_extraction_works_on_a_pymjcf_attached_model_with_prefixed_names(arm):
    root = mjcf.RootElement(model="holder")
    t3 = mjcf.from_path(str(constants.T3_XML))
    root.attach(t3)
    physics = mjcf.Physics.from_mjcf_model(root)
    assert "t3/shoulder_joint" in physics.named.model.jnt_range.axes.row.names
    attached = arm_from_model(physics)
    np.testing.assert_allclose(attached.links, arm.links, atol=1e-12)
    np.testing.assert_allclose(attached.shoulder_xz, arm.shoulder_xz, atol=1e-12)
    np.testing.assert_allclose(attached.link_masses, arm.link_masses)


def test_extraction_rejects_a_model_without_the_arm():
    model = mujoco.MjModel.from_xml_string("<mujoco><worldbody><geom size='1'/></worldbody></mujoco>")
    with pytest.raises(ModelError, match="waist_joint"):
        arm_from_model(model)


def test_extraction_rejects_a_non_planar_wrist():
    root = mjcf.from_path(str(constants.T3_XML))
    root.find("joint", "elbow_joint").axis = [0, -1, 0.2]  # tilted: no longer parallel to the shoulder
    model = mjcf.Physics.from_mjcf_model(root).model.ptr
    with pytest.raises(ModelError, match="elbow_joint"):
        arm_from_model(model)
