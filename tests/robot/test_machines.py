"""The trenching machines (excavsim.robot.machine): the description, and the force constraint's torque limits
for cylinders (Singh 1995 §5.3 with relief pressure x area x moment arm) against the closed forms of
excavsim.robot.cylinders and MuJoCo's own tendon lengths."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from excavsim import constants
from excavsim.config import load_planner_config, load_trench_goal
from excavsim.errors import ConfigError
from excavsim.planning.constraints import PoseTorqueLimits
from excavsim.robot.excavators import TB035
from excavsim.robot.machine import MACHINES, T3, get_machine

FUNCTIONS = ("boom", "stick", "bucket")


def test_unknown_machine_is_refused_naming_the_allowed_ones():
    with pytest.raises(ConfigError, match="unknown trenching machine 'tb036'; allowed: t3, tb035, excavator_25t"):
        get_machine("tb036")


def test_the_descriptions_name_joints_the_models_have():
    """Every named joint exists in the machine's scene, the waist first and the planar chain next."""
    for name, m in MACHINES.items():
        xml = constants.SCENE_XML if name == "t3" else constants.MODELS_DIR / name / "scene.xml"
        model = mujoco.MjModel.from_xml_path(str(xml))
        for j in m.joints:
            assert model.joint(j).id >= 0
        assert m.joints[0] == m.waist and m.joints[1:4] == m.planar
    assert T3.chain_joints is None and T3.held == (("wrist_yaw_joint", 0.0), ("wrist_roll_joint", 0.0))
    assert get_machine("tb035").chain_joints == ("swing_joint", "boom_joint", "stick_joint", "bucket_joint")
    with pytest.raises(ConfigError, match="actuator force ranges"):
        T3.torque_limits(np.zeros(3))


def _expected(q: np.ndarray, tau_sign: float) -> np.ndarray:
    """Relief pressure x (piston or annulus) area x |dL/dq| from the cylinders' own numbers, in the
    direction of a torque of sign ``tau_sign`` at planar joint angles ``q`` (3,)."""
    out = []
    for j, f in enumerate(FUNCTIONS):
        c = TB035.cylinder(f)
        piston = math.pi * c.bore_m ** 2 / 4 * c.count
        annulus = math.pi * (c.bore_m ** 2 - c.rod_m ** 2) / 4 * c.count
        m = float(TB035.moment_arm(f, q[j]))
        pushes = (m > 0) == (tau_sign > 0)  # a pushing (extending) cylinder turns the joint along dL/dq
        out.append(TB035.relief_pa * (piston if pushes else annulus) * abs(m))
    return np.array(out)


def _mujoco_moment_arms(q: np.ndarray) -> np.ndarray:
    """dL/dq of the three cylinders from MuJoCo's tendon lengths (central differences), the linkage closed."""
    model = mujoco.MjModel.from_xml_path(str(TB035.scene_xml))
    data = mujoco.MjData(model)
    lk = TB035.linkage

    def lengths(qq):
        for jn, v in zip(("boom_joint", "stick_joint", "bucket_joint"), qq):
            data.qpos[model.jnt_qposadr[model.joint(jn).id]] = v
        data.qpos[model.jnt_qposadr[model.joint("rocker_joint").id]] = float(lk.rocker_angle(qq[2]))
        data.qpos[model.jnt_qposadr[model.joint("link_joint").id]] = float(lk.link_angle(qq[2]) - lk.rocker_angle(qq[2]))
        mujoco.mj_kinematics(model, data)
        mujoco.mj_tendon(model, data)
        return np.array([data.ten_length[model.tendon(f"{f}_cylinder").id] for f in FUNCTIONS])

    h = 1e-6
    return np.array([(lengths(q + h * np.eye(3)[j]) - lengths(q - h * np.eye(3)[j]))[j] / (2 * h) for j in range(3)])


def test_the_planners_limits_for_the_tb035_are_relief_times_area_times_moment_arm():
    """At sampled poses and both directions, the planner's limit is p A |dL/dq| (the closed forms), and the
    moment arms are MuJoCo's tendon's; it varies over the range (by more than a third for every joint)."""
    from excavsim.rig.core import planner_limits

    limits = planner_limits(None, get_machine("tb035"))
    assert isinstance(limits, PoseTorqueLimits)
    rng = np.random.default_rng(3)
    lo, hi = np.array(TB035.arm.lower[1:]), np.array(TB035.arm.upper[1:])
    for q in rng.uniform(lo, hi, size=(6, 3)):
        for sign in (1.0, -1.0):
            got = limits.magnitude(q, np.full(3, sign))
            np.testing.assert_allclose(got, _expected(q, sign), rtol=1e-12)
        np.testing.assert_allclose(np.abs([TB035.moment_arm(f, q[j]) for j, f in enumerate(FUNCTIONS)]),
                                   np.abs(_mujoco_moment_arms(q)), rtol=1e-4)
    sweep = np.linspace(lo, hi, 50)
    pos = limits.magnitude(sweep, np.ones((50, 3)))
    assert np.all(pos.max(axis=0) > 1.33 * pos.min(axis=0))
    # the constant stand-in is the weakest over the range; a torque margin divides every limit
    np.testing.assert_allclose(limits.nominal, TB035.planner_torque_limits())
    np.testing.assert_allclose((limits / 2.0).magnitude(sweep, np.ones((50, 3))), pos / 2.0)


def test_the_force_constraint_compares_each_torque_with_the_limit_at_its_pose():
    """The planner's torque ratio at a pose is |tau| / (p A |dL/dq|) there, not over one constant."""
    from excavsim.rig.core import make_planner
    from excavsim.world.machines import make_world
    from excavsim.config import get_soil
    from excavsim.robot.extract import arm_from_model

    m = get_machine("tb035")
    world = make_world("tb035")
    arm = arm_from_model(world.model, joints=m.chain_joints)
    goal = load_trench_goal(constants.TRENCHES_DIR / "tb035" / "sand.yaml")
    limits = PoseTorqueLimits(m.torque_limits, TB035.planner_torque_limits())
    planner = make_planner(arm, limits, 0.55, 0.064, goal, load_planner_config(), get_soil("testbed_sand"),
                           table_spec=m.table)
    assert not planner.uses_kernel()
    poses = np.array([[2.8, -0.2, math.radians(30)], [3.3, -0.1, math.radians(45)], [2.4, -0.3, math.radians(20)]])
    depth, load = np.full(3, 0.2), np.full(3, 0.03)
    _, tau, ratio = planner.torque_ratio(poses, depth, load)
    q, ok = arm.inverse(poses)
    assert ok.all()
    want = np.max(np.abs(tau) / np.array([np.where(tau[i] >= 0, _expected(q[i], 1.0), _expected(q[i], -1.0))
                                          for i in range(3)]), axis=-1)
    np.testing.assert_allclose(ratio, want, rtol=1e-9)
    assert not np.allclose(ratio, np.max(np.abs(tau) / limits.nominal, axis=-1))
