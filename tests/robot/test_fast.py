"""The compiled IK and static torques equal the numpy kinematics (which MuJoCo checks)."""

from __future__ import annotations

import numpy as np

from excavsim.robot.fast import arm_params, ik_torques
from excavsim.robot.statics import static_joint_torques


def test_compiled_ik_and_torques_equal_the_numpy_reference(arm, rng):
    n = 20_000
    q = rng.uniform(arm.lower, arm.upper, (n, 3))
    poses = arm.forward(q)
    poses[:2000] += rng.normal(0.0, 1.0, (2000, 3))  # many of these are out of reach
    wrench = rng.normal(0.0, 500.0, (n, 3))
    payload = rng.uniform(0.0, 50.0, n)
    load_tip = np.array([-0.2, 0.12])
    q_out, ok, tau = np.empty((n, 3)), np.empty(n, bool), np.empty((n, 3))
    ik_torques(arm_params(arm), poses, wrench, payload, load_tip, True, q_out, ok, tau)
    q_ref, ok_ref = arm.inverse(poses)
    tau_ref = static_joint_torques(arm, np.where(ok_ref[:, None], q_ref, 0.0), wrench, payload_kg=payload,
                                   payload_com_tip=load_tip)
    np.testing.assert_array_equal(ok, ok_ref)
    assert 0.05 < (~ok).mean() < 0.5
    np.testing.assert_allclose(q_out[ok], q_ref[ok], atol=1e-12)
    np.testing.assert_allclose(tau[ok], tau_ref[ok], atol=1e-8)
    assert np.isnan(q_out[~ok]).all() and np.isnan(tau[~ok]).all()
