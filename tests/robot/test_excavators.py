"""The excavator models (models/tb035, models/excavator_25t): MuJoCo's kinematics against the closed forms
of excavsim.robot.cylinders, the cylinders' kinematics against finite differences, Table 4.2's joint
limits, relief pressure as the force limit, pump flow shared as Rowe 1997 §4.0, and the generator."""

from __future__ import annotations

import math
import subprocess
import sys

import mujoco
import numpy as np
import pytest

from excavsim import constants
from excavsim.errors import ExcavsimError
from excavsim.robot.cylinders import Cylinder, PinTriangle, share_pump_flow
from excavsim.robot.excavators import MACHINES, PUMPS, TB035, get_machine
from excavsim.world.hydraulics import EXCAVATOR_JOINTS, ExcavatorWorld, HydraulicDrive

NAMES = sorted(MACHINES)


def _load(name: str) -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = mujoco.MjModel.from_xml_path(str(constants.MODELS_DIR / name / "scene.xml"))
    return model, mujoco.MjData(model)


def _random_q(spec, rng, n):
    lo, hi = np.array(spec.arm.lower), np.array(spec.arm.upper)
    return rng.uniform(lo, hi, size=(n, 4))


def _set_pose(model, data, spec, q):
    """Write (swing, boom, stick, bucket) and the linkage's closed-form angles into qpos."""
    lk = spec.linkage
    rho, lam = float(lk.rocker_angle(q[3])), float(lk.link_angle(q[3]))
    for j, v in zip(EXCAVATOR_JOINTS, q):
        data.qpos[model.jnt_qposadr[model.joint(j).id]] = v
    data.qpos[model.jnt_qposadr[model.joint("rocker_joint").id]] = rho
    data.qpos[model.jnt_qposadr[model.joint("link_joint").id]] = lam - rho
    mujoco.mj_fwdPosition(model, data)


@pytest.mark.parametrize("name", NAMES)
def test_mujoco_kinematics_equal_the_closed_forms(name, rng):
    spec = get_machine(name)
    model, data = _load(name)
    tip = model.site("bucket_tip").id
    link_end = model.eq("bucket_link_pin").data[:3]
    for q in _random_q(spec, rng, 40):
        _set_pose(model, data, spec, q)
        np.testing.assert_allclose(data.site_xpos[tip], spec.arm.tip(q), atol=1e-9)
        # the blade's direction (the tip site's x axis) in the arm plane
        x_axis = data.site_xmat[tip].reshape(3, 3)[:, 0]
        radial = np.array([math.cos(q[0]), math.sin(q[0]), 0.0])
        phi = math.atan2(x_axis[2], x_axis @ radial)
        assert math.remainder(phi - spec.arm.planar(q)[2], 2 * math.pi) == pytest.approx(0.0, abs=1e-9)
        # the linkage's loop is closed by the closed form's angles: the link's end is on the bucket's pin
        link, bucket = model.body("link").id, model.body("bucket").id
        end = data.xpos[link] + data.xmat[link].reshape(3, 3) @ link_end
        pin = data.xpos[bucket] + data.xmat[bucket].reshape(3, 3) @ model.eq("bucket_link_pin").data[3:6]
        np.testing.assert_allclose(end, pin, atol=1e-9)
        # the cylinders' lengths: MuJoCo's tendons against the law of cosines and the four-bar
        for j, f in ((1, "boom"), (2, "stick"), (3, "bucket")):
            assert data.actuator_length[model.actuator(f).id] == pytest.approx(
                float(spec.cylinder_length(f, q[j])), abs=1e-9)


@pytest.mark.parametrize("name", NAMES)
def test_mujoco_jacobian_equals_finite_differences_of_the_closed_form(name, rng):
    spec = get_machine(name)
    model, data = _load(name)
    tip = model.site("bucket_tip").id
    dofs = [model.jnt_dofadr[model.joint(j).id] for j in EXCAVATOR_JOINTS]
    jacp = np.zeros((3, model.nv))
    h = 1e-6
    for q in _random_q(spec, rng, 20):
        _set_pose(model, data, spec, q)
        mujoco.mj_jacSite(model, data, jacp, None, tip)
        fd = np.stack([(spec.arm.tip(q + h * e) - spec.arm.tip(q - h * e)) / (2 * h) for e in np.eye(4)], axis=-1)
        np.testing.assert_allclose(jacp[:, dofs], fd, atol=1e-6)
        np.testing.assert_allclose(spec.arm.jacobian(q), fd, atol=1e-6)


@pytest.mark.parametrize("name", NAMES)
def test_cylinder_moment_arms_equal_finite_differences_of_the_lengths(name):
    spec = get_machine(name)
    h = 1e-6
    for j, f in ((1, "boom"), (2, "stick"), (3, "bucket")):
        q = np.linspace(spec.arm.lower[j], spec.arm.upper[j], 50)
        fd = (spec.cylinder_length(f, q + h) - spec.cylinder_length(f, q - h)) / (2 * h)
        np.testing.assert_allclose(spec.moment_arm(f, q), fd, atol=1e-7)
        # each stroke spans the joint's range exactly: the stroke ends are the limits' lengths
        cyl = spec.cylinder(f)
        ends = sorted(float(spec.cylinder_length(f, spec.arm.lower[j] if k == 0 else spec.arm.upper[j])) for k in (0, 1))
        assert ends == pytest.approx([cyl.retracted_m, cyl.extended_m], abs=1e-9)


def test_pin_triangle_inverse_and_law_of_cosines():
    tri = PinTriangle((0.3, -0.2), (1.0, 0.4))
    q = np.linspace(-0.5, 1.5, 9)
    a, b = math.hypot(0.3, -0.2), math.hypot(1.0, 0.4)
    # the pins' distance directly, the child pin turned by q
    child = np.stack([np.cos(q) * 1.0 - np.sin(q) * 0.4, np.sin(q) * 1.0 + np.cos(q) * 0.4], -1)
    np.testing.assert_allclose(tri.length(q), np.linalg.norm(child - [0.3, -0.2], axis=-1), atol=1e-12)
    assert tri.a == pytest.approx(a) and tri.b == pytest.approx(b)
    np.testing.assert_allclose(tri.joint_angle(tri.length(q), branch_q=0.5), q, atol=1e-9)


def test_tb035_joint_limits_are_dimaio_table_4_2_exactly():
    model, _ = _load("tb035")
    table = {"boom_joint": (-1.085, 1.2075), "stick_joint": (-2.6927, -0.6102), "bucket_joint": (-2.6843, 0.5182)}
    for joint, limits in table.items():
        assert tuple(model.jnt_range[model.joint(joint).id]) == limits
    assert (TB035.arm.lower[1:], TB035.arm.upper[1:]) == ((-1.085, -2.6927, -2.6843), (1.2075, -0.6102, 0.5182))


@pytest.mark.parametrize("name", NAMES)
def test_model_survives_one_second_of_noisy_control_without_warnings(name, rng):
    model, data = _load(name)
    for key in [None, *range(model.nkey)]:
        if key is None:
            mujoco.mj_resetData(model, data)
        else:
            mujoco.mj_resetDataKeyframe(model, data, key)
        lo, hi = model.actuator_ctrlrange.T
        for _ in range(int(1.0 / model.opt.timestep)):
            data.ctrl[:] = rng.uniform(lo, hi)
            mujoco.mj_step(model, data)
        assert all(w.number == 0 for w in data.warning), [mujoco.mjtWarning(i).name for i, w in
                                                          enumerate(data.warning) if w.number]
        assert np.all(np.isfinite(data.qpos))


@pytest.mark.parametrize("name", NAMES)
def test_relief_pressure_caps_the_cylinder_force(name):
    """A load far beyond the boom's strength on the bucket: the boom cylinder pushes at exactly the relief
    pressure times its piston area, and gives way."""
    spec = get_machine(name)
    model, data = _load(name)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    boom = model.actuator("boom").id
    q0 = data.qpos[model.jnt_qposadr[model.joint("boom_joint").id]]
    bore = {"tb035": 0.080, "excavator_25t": 0.140}[name]
    count = {"tb035": 1, "excavator_25t": 2}[name]
    relief = {"tb035": 20.6e6, "excavator_25t": 34.3e6}[name]
    push = relief * count * math.pi / 4 * bore ** 2
    data.xfrc_applied[model.body("bucket").id, 2] = -4.0 * push  # down, at the bucket
    forces = []
    for _ in range(150):
        mujoco.mj_step(model, data)
        forces.append(data.actuator_force[boom])
    assert max(forces) == pytest.approx(push, rel=1e-9)
    assert max(forces) <= push * (1 + 1e-9)  # the file holds 12 significant digits
    assert data.sensor("boom_cylinder_force").data[0] == pytest.approx(push, rel=1e-9)
    assert data.qpos[model.jnt_qposadr[model.joint("boom_joint").id]] < q0 - 0.01  # the boom gave way
    # the spec's torque limit at that pose is that force times the moment arm
    lim = spec.joint_torque_limits(np.array(spec.ref))[1]
    assert lim[1] == pytest.approx(push * float(spec.moment_arm("boom", spec.ref[1])), rel=1e-9)


def test_pump_flow_is_shared_between_the_two_functions_of_a_pump():
    assert share_pump_flow(np.array([1.0, 1.0, 0.5, 0.0]), ((0, 1), (2, 3)), 1.5).tolist() == [0.75, 0.75, 1, 1]
    with pytest.raises(ExcavsimError, match=">= 0"):
        share_pump_flow(np.array([-1.0]), ((0,),), 1.0)
    model, data = _load("tb035")
    drive = HydraulicDrive(TB035, model)
    ref = np.array(TB035.ref)
    setpoints = drive.lengths(ref)
    far = ref.copy()
    far[1] = TB035.arm.upper[1]  # boom all the way up: its cylinder alone takes a pump's whole flow
    alone = drive.rates(far, setpoints)
    assert drive.flows(alone)[1] == pytest.approx(TB035.pump_flow_m3_s)
    both = far.copy()
    both[3] = TB035.arm.lower[3]  # and the bucket curled, on the same pump (Rowe 1997 §4.0)
    shared = drive.rates(both, setpoints)
    flows = drive.flows(shared)
    assert flows[1] + flows[3] == pytest.approx(TB035.pump_flow_m3_s)
    assert 0 < shared[1] < alone[1]
    assert set(PUMPS[0]) == {1, 3}
    with pytest.raises(ExcavsimError, match="within"):
        drive.rates(np.array([0.0, 2.0, -1.0, 0.0]), setpoints)


def test_cylinder_limits_are_relief_times_area_and_flow_over_area():
    c = Cylinder(bore_m=0.1, rod_m=0.05, retracted_m=1.0, stroke_m=0.6, count=2)
    pull, push = c.force_limits(20e6)
    assert push == pytest.approx(20e6 * 2 * math.pi / 4 * 0.01)
    assert pull == pytest.approx(20e6 * 2 * math.pi / 4 * (0.01 - 0.0025))
    v_ret, v_ext = c.speed_limits(1e-3)
    assert v_ext == pytest.approx(1e-3 / (2 * math.pi / 4 * 0.01))
    assert v_ret > v_ext
    with pytest.raises(ExcavsimError, match="rod < bore"):
        Cylinder(bore_m=0.05, rod_m=0.06, retracted_m=1.0, stroke_m=0.5)


def test_the_models_soil_model_digs_in_the_pit():
    world = ExcavatorWorld("tb035", "dry_sand", seed=0)
    q = world.joint_angles()
    before = world.soil.volumes()
    for _ in range(100):  # lower the boom into the soil, then curl the bucket
        world.step(np.array([0.0, q[1] - 0.25, q[2] - 0.2, q[3]]))
    for _ in range(100):
        world.step(np.array([0.0, q[1] - 0.25, q[2] - 0.4, -2.3]))
    after = world.soil.volumes()
    assert after.bucket > 0.005
    assert after.total == pytest.approx(before.total, rel=1e-9)
    assert abs(world.cylinder_forces()[3]) > 0


def test_committed_models_equal_the_generator_output():
    script = constants.REPO_ROOT / "scripts" / "make_excavators.py"
    result = subprocess.run([sys.executable, str(script), "--check"], capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr


def test_the_own_machine_example_digs_the_soil_box():
    """docs/concepts/own-machine.md's example: a user's gantry with the bucket names fills its bucket."""
    import importlib.util

    path = constants.REPO_ROOT / "examples" / "own_machine.py"
    spec = importlib.util.spec_from_file_location("own_machine", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    result = module.dig()
    assert result["mujoco_warnings"] == 0
    assert result["in_bucket_m3"] > 0.5 * module.SHAPE.struck_capacity_m3()
    assert result["cut_from_box_m3"] >= result["in_bucket_m3"]
    assert abs(result["volume_error_m3"]) < 1e-9
    assert result["peak_cutting_force_n"] > 100.0


@pytest.mark.parametrize("name", NAMES)
def test_the_planar_chain_read_from_the_model_is_the_closed_form(name, rng):
    """arm_from_model with the excavator's joint names gives the planner's PlanarArm of the machine: its
    forward kinematics are the spec's closed form and its inverse (elbow up) recovers the joints."""
    from excavsim.robot.extract import arm_from_model
    from excavsim.robot.kinematics import wrap_angle

    spec = get_machine(name)
    model, _ = _load(name)
    arm = arm_from_model(model, joints=EXCAVATOR_JOINTS)
    q = _random_q(spec, rng, 200)
    pose = arm.forward(q[:, 1:])
    planar = spec.arm.planar(q)
    np.testing.assert_allclose(pose[:, :2], planar[:, :2], atol=1e-9)
    np.testing.assert_allclose(wrap_angle(pose[:, 2] - (planar[:, 2] - np.pi)), 0.0, atol=1e-9)  # pitch = rake
    back, ok = arm.inverse(pose)
    assert ok.all()
    np.testing.assert_allclose(back, q[:, 1:], atol=1e-9)
    np.testing.assert_allclose(arm.lower, spec.arm.lower[1:])
    np.testing.assert_allclose(arm.upper, spec.arm.upper[1:])
    with pytest.raises(Exception, match="waist, shoulder, elbow, wrist"):
        arm_from_model(model, joints=EXCAVATOR_JOINTS[:3])


def test_the_tb035_digs_a_trench_with_its_planar_chain():
    """examples/tb035_trench.py: three passes, each filling the bucket, leave a trench 0.35 m deep or more
    along its middle (0.34 m at its shallow end: 0.3485 m since the linkage's armature settled the bucket servo,
    0.35 before), with the volume account closed and no cylinder beyond relief."""
    import importlib.util

    path = constants.REPO_ROOT / "examples" / "tb035_trench.py"
    spec = importlib.util.spec_from_file_location("tb035_trench", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    r = module.trench(seed=0)
    middle = (r["x_m"] >= 2.8) & (r["x_m"] <= 3.3)
    assert r["surface_z_m"][middle].max() < -0.34
    assert np.median(r["surface_z_m"][middle]) < -0.45
    assert r["surface_z_m"][r["x_m"] >= 4.3].min() == pytest.approx(0.0, abs=1e-6)  # beyond the trench: untouched
    heaped = 1.25 * TB035.bucket.struck_capacity_m3()
    assert min(r["bucket_per_pass_m3"]) > 0.9 * heaped
    assert abs(r["volume_error_m3"]) < 1e-9
    limits = [TB035.swing_motor.torque_limit()] + [max(TB035.cylinder(f).force_limits(TB035.relief_pa))
                                                    for f in ("boom", "stick", "bucket")]
    assert np.all(r["peak_forces_at_lift_out"] <= np.array(limits) * (1 + 1e-9))


def test_planner_torque_limits_are_the_weakest_relief_torques_over_the_range():
    """Singh 1995 §5.3's constant relief torque becomes p A |dL/dq|, pose- and direction-dependent; the
    planner's constant is its smallest value over the range (or a sub-range)."""
    limits = TB035.planner_torque_limits()
    for j, f in enumerate(("boom", "stick", "bucket")):
        q = np.linspace(TB035.arm.lower[j + 1], TB035.arm.upper[j + 1], 2001)
        pull, push = TB035.cylinder(f).force_limits(TB035.relief_pa)
        weakest = float(np.min(np.abs(TB035.moment_arm(f, q))) * min(pull, push))
        assert limits[j] == pytest.approx(weakest, rel=1e-3)
    narrow = TB035.planner_torque_limits(lower=(-0.2, -2.0, -2.0), upper=(0.5, -1.0, -0.5))
    assert np.all(narrow >= limits)
    with pytest.raises(ExcavsimError, match="within the joint limits"):
        TB035.planner_torque_limits(lower=(-2.0, -2.0, -2.0), upper=(0.5, -1.0, -0.5))


@pytest.mark.parametrize("name", NAMES)
def test_every_name_the_soil_model_and_the_loop_read_exists(name):
    from excavsim.world.bucket import BucketGeometry

    model, _ = _load(name)
    for site in ("cab_scanner_left", "cab_scanner_right", "scanner", "ft_mount", "bucket_tip",
                 *(f"bucket_profile_{i}" for i in range(constants.N_BUCKET_PROFILE_SITES)),
                 *(f"survey_target_{i}" for i in range(constants.N_SURVEY_TARGETS))):
        assert model.site(site).id >= 0
    for sensor in ("ft_force", "ft_torque", "swing_torque", "boom_cylinder_force", "stick_cylinder_force",
                   "bucket_cylinder_force"):
        assert model.sensor(sensor).id >= 0
    bucket = BucketGeometry.from_model(model)
    spec = get_machine(name)
    assert bucket.width == pytest.approx(spec.bucket.width_m)
    assert bucket.capacity == pytest.approx(spec.bucket.struck_capacity_m3(), rel=1e-9)
    for key in ("home", "park"):
        assert model.key(key).id >= 0
