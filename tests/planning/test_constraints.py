"""The constraints of ch. 4 and §5.3, one function each, on small hand-made paths."""

from __future__ import annotations

import numpy as np
import pytest

from excavsim.config import TrenchGoal
from excavsim.handoff.goal import SurfaceProfile, goal_profile
from excavsim.planning.constraints import (ArmStatics, force, reachability, sensible, sensible_curl, shaping,
                                           torque_ratio, volume)
from excavsim.robot.statics import static_joint_torques

# 0.3 m deep below the 0.5 m surface; the near wall at 45 deg from x 1.7 to 2.0, the far wall vertical at 2.9
GOAL = TrenchGoal(near_x_m=1.7, far_x_m=2.9, depth_m=0.3, near_wall_deg=45.0, far_wall_deg=90.0)
FLAT = SurfaceProfile(np.array([0.0, 4.0]), np.array([0.5, 0.5]))
LOAD_TIP = np.array([-0.2, 0.12])  # configs/planner.yaml payload_com_tip_m
LIMITS = np.array([25000.0, 12000.0, 1000.0])


def _path(x, z, pitch=0.5) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    return np.stack([x, np.broadcast_to(z, x.shape), np.broadcast_to(pitch, x.shape)], axis=-1)


def test_goal_profile_follows_the_walls_and_bottom():
    z = goal_profile(GOAL, np.array([1.0, 1.7, 1.8, 2.5, 2.89, 3.2]))
    np.testing.assert_allclose(z, [0.5, 0.5, 0.4, 0.2, 0.2, 0.5])


def test_shaping_fails_the_sample_of_a_path_that_dips_a_centimetre_below_the_goal():
    x = np.linspace(2.8, 2.1, 15)
    along = _path(x, 0.2)  # on the bottom
    assert shaping(along, GOAL, 0.005).all()
    dip = along.copy()
    dip[7, 1] = 0.19
    verdict = shaping(dip, GOAL, 0.005)
    assert not verdict[7] and verdict.sum() == 14
    dip[7, 1] = 0.196  # 4 mm below: within the 5 mm tolerance
    assert shaping(dip, GOAL, 0.005).all()
    # Beside the trench the goal is the surface itself: any cut there fails.
    assert not shaping(_path([1.5, 3.0], 0.49), GOAL, 0.005).any()
    # Vectorized over paths: (2, 15) verdicts for two paths.
    assert shaping(np.stack([along, dip]), GOAL, 0.0).sum(axis=1).tolist() == [15, 14]


def test_sensible_fails_the_samples_above_the_soil():
    x = np.linspace(2.6, 2.0, 13)
    z = np.full(13, 0.45)
    z[4], z[8] = 0.52, 0.505  # 2 cm above the surface; 5 mm above, within the 1 cm tolerance
    verdict = sensible(_path(x, z), FLAT, 0.01)
    assert not verdict[4] and verdict.sum() == 12
    pit = SurfaceProfile(np.array([0.0, 2.2, 2.21, 2.39, 2.4, 4.0]), np.array([0.5, 0.5, 0.3, 0.3, 0.5, 0.5]))
    through_pit = sensible(_path(x, 0.45), pit, 0.01)  # a drag 5 cm deep runs through the 20 cm pit's air
    np.testing.assert_array_equal(through_pit, (x <= 2.2) | (x >= 2.4))


def test_a_curl_must_have_turned_to_the_exit_pitch_before_the_edge_leaves_the_soil():
    """§4.3.6: soil spills if the bucket is still open when the edge rises out of the soil."""
    z = np.array([0.45, 0.48, 0.50, 0.52, 0.55])  # leaves the soil (beyond 1 cm) at sample 3
    late = _path(np.full(5, 2.0), z, np.array([0.6, 0.4, 0.2, 0.1, -0.2]))  # still at 0.1 rad there
    curled = _path(np.full(5, 2.0), z, np.array([0.6, 0.4, 0.2, -0.1, -0.2]))
    assert not sensible_curl(late, FLAT, 0.01, 0.0)
    assert sensible_curl(curled, FLAT, 0.01, 0.0)
    assert sensible_curl(late, FLAT, 0.01, 0.1)  # the exit pitch reached exactly
    buried = _path(np.full(5, 2.0), 0.4, np.array([0.6, 0.4, 0.2, 0.1, 0.05]))
    assert sensible_curl(buried, FLAT, 0.01, -1.0)  # never leaves the soil: nothing spills
    np.testing.assert_array_equal(sensible_curl(np.stack([late, curled, buried]), FLAT, 0.01, 0.0),
                                  [False, True, True])


def test_volume_allows_up_to_the_limit():
    np.testing.assert_array_equal(volume(np.array([0.0, 0.0204, 0.02041]), 0.0204), [True, True, False])


def test_reachability_accepts_the_poses_the_arm_reaches_with_their_joint_angles(arm, reach_table):
    statics = ArmStatics(arm, reach_table, LOAD_TIP)
    poses = np.array([[[2.4, 0.4, 0.6], [2.0, 0.3, 0.3]], [[4.5, 0.5, 0.3], [2.2, 0.4, 3.0]]])
    ok, q = reachability(poses, statics)
    np.testing.assert_array_equal(ok, [[True, True], [False, False]])
    np.testing.assert_array_equal(ok, arm.reachable(poses))  # the table and the exact IK agree here
    np.testing.assert_allclose(arm.forward(q[ok]), poses[ok], atol=1e-9)
    assert np.isnan(q[~ok]).all()


class _ConstantForce:
    """The soil pushes with the same force (F_x, F_z) [N] at every sample."""

    def __init__(self, fx: float, fz: float):
        self.f = np.array([fx, fz])

    def predict(self, depth, rake, volume, context=None):
        return np.broadcast_to(self.f, np.shape(depth) + (2,)).copy()


def test_torque_ratio_is_the_static_torques_of_eq_28_over_the_limits(arm, reach_table):
    statics = ArmStatics(arm, reach_table, LOAD_TIP)
    poses = np.array([[2.4, 0.4, 0.6], [2.0, 0.3, 0.3], [4.5, 0.5, 0.3]])
    load = np.array([0.005, 0.01, 0.01])
    push = _ConstantForce(300, -200)
    forces, tau, ratio = torque_ratio(poses, np.full(3, 0.1), load, statics=statics, predictor=push, density=2000.0,
                                      limits=LIMITS)
    np.testing.assert_array_equal(forces, [[300, -200]] * 3)
    q, _ = arm.inverse(poses[:2])
    expected = static_joint_torques(arm, q, np.array([300.0, -200.0, 0.0]), payload_kg=2000.0 * load[:2],
                                    payload_com_tip=LOAD_TIP)
    np.testing.assert_allclose(tau[:2], expected, atol=1e-8)
    np.testing.assert_allclose(ratio[:2], np.max(np.abs(expected) / LIMITS, axis=1), rtol=1e-12)
    assert ratio[2] == np.inf and np.isnan(tau[2]).all()  # unreachable: no torques, never within limits
    _, _, free = torque_ratio(poses, np.full(3, 0.1), load, statics=statics, predictor=push, density=2000.0,
                              limits=np.full(3, np.inf))
    np.testing.assert_array_equal(free, [0.0, 0.0, np.inf])  # no limits: only reachability can fail


def test_force_passes_up_to_the_limit_and_never_where_unreachable():
    np.testing.assert_array_equal(force(np.array([0.0, 1.0, 1.0 + 1e-12, np.inf])), [True, True, False, False])


@pytest.mark.parametrize("limit, ok", [(1e9, True), (1.0, False)])
def test_force_follows_the_wrist_limit(arm, reach_table, limit, ok):
    statics = ArmStatics(arm, reach_table, LOAD_TIP)
    poses = np.array([[2.4, 0.4, 0.6]])
    _, _, ratio = torque_ratio(poses, np.array([0.1]), np.array([0.01]), statics=statics,
                               predictor=_ConstantForce(300, -200), density=2000.0,
                               limits=np.array([1e9, 1e9, limit]))
    assert bool(force(ratio)[0]) is ok
