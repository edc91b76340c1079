"""Menagerie-style model tests: every scene loads both ways, 1 s of noisy control raises no MuJoCo
warning, every name the code uses exists, and the committed bucket matches its generator."""

from __future__ import annotations

import importlib.util
import pathlib
import sys

import mujoco
import numpy as np
import pytest
from dm_control import mjcf

from excavsim import constants
from excavsim.config import SceneConfig, load_robot_config
from excavsim.world.scene import build_physics, build_scene

SCENES = sorted(constants.MODELS_DIR.glob("*/scene*.xml"))


def test_scene_files_exist():
    assert constants.SCENE_XML in SCENES


def _assert_no_warnings(model: mujoco.MjModel, data: mujoco.MjData, where: str) -> None:
    for i, w in enumerate(data.warning):
        assert w.number == 0, f"{where}: MuJoCo warning {mujoco.mjtWarning(i).name} raised {w.number} times"


def _noisy_control(model: mujoco.MjModel, data: mujoco.MjData, rng: np.random.Generator, seconds: float = 1.0):
    lo, hi = model.actuator_ctrlrange.T
    for _ in range(int(seconds / model.opt.timestep)):
        data.ctrl[:] = rng.uniform(lo, hi)
        mujoco.mj_step(model, data)


@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.name)
def test_scene_loads_and_survives_noisy_control(path: pathlib.Path, rng):
    model = mujoco.MjModel.from_xml_path(str(path))
    for key in [None, *range(model.nkey)]:
        data = mujoco.MjData(model)
        if key is None:
            mujoco.mj_resetData(model, data)
        else:
            mujoco.mj_resetDataKeyframe(model, data, key)
        _noisy_control(model, data, rng)
        _assert_no_warnings(model, data, f"{path.name} from {'default' if key is None else model.key(key).name}")
        assert np.all(np.isfinite(data.qpos))


@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.name)
def test_scene_loads_through_pymjcf_physics(path: pathlib.Path, rng):
    physics = mjcf.Physics.from_mjcf_model(mjcf.from_path(str(path)))
    reference = mujoco.MjModel.from_xml_path(str(path))
    assert (physics.model.nq, physics.model.nu, physics.model.nbody) == (reference.nq, reference.nu, reference.nbody)
    _noisy_control(physics.model.ptr, physics.data.ptr, rng)
    _assert_no_warnings(physics.model.ptr, physics.data.ptr, f"{path.name} via PyMJCF")


def test_every_name_the_code_uses_exists():
    physics = build_physics()
    named = physics.named.model
    for j in constants.JOINTS:
        assert j in named.jnt_range.axes.row.names
    for a in constants.ACTUATORS:
        assert a in named.actuator_gear.axes.row.names
    sites = list(named.site_pos.axes.row.names)
    expected = [constants.BUCKET_TIP_SITE, constants.FT_SITE, constants.SCANNER_SITE]
    expected += [f"{constants.BUCKET_PROFILE_SITE_PREFIX}{i}" for i in range(constants.N_BUCKET_PROFILE_SITES)]
    expected += [f"{constants.SURVEY_TARGET_SITE_PREFIX}{i}" for i in range(constants.N_SURVEY_TARGETS)]
    for s in expected:
        assert s in sites, s
    assert constants.BUCKET_BODY in named.body_mass.axes.row.names
    assert constants.SOIL_BOX_BODY in named.body_mass.axes.row.names
    assert constants.SOIL_GEOM in named.geom_type.axes.row.names
    for sensor in (constants.FT_FORCE_SENSOR, constants.FT_TORQUE_SENSOR):
        assert sensor in named.sensor_adr.axes.row.names
    m = physics.model.ptr
    assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_HFIELD, constants.SOIL_HFIELD) >= 0
    for numeric in (constants.BUCKET_WIDTH_NUMERIC, constants.BUCKET_CAPACITY_NUMERIC):
        assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_NUMERIC, numeric) >= 0
    for key in constants.KEYFRAMES:
        assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, key) >= 0


def test_keyframes_hold_set_points_equal_to_joint_angles(mj_model):
    for k in range(mj_model.nkey):
        np.testing.assert_array_equal(mj_model.key_act[k], mj_model.key_qpos[k])


def test_bucket_does_not_collide_with_soil_but_does_with_walls(mj_model):
    soil = mj_model.geom("soil")
    assert soil.contype == 0 and soil.conaffinity == 0
    bucket_id = mj_model.body("bucket").id
    collision = [g for g in range(mj_model.ngeom)
                 if mj_model.geom_bodyid[g] == bucket_id and mj_model.geom_group[g] == 3]
    assert len(collision) >= 3
    wall = mj_model.geom("wall_far")
    for g in collision:
        assert mj_model.geom_contype[g] & wall.conaffinity


def test_configuration_is_applied_to_the_scene():
    robot = load_robot_config()
    weaker = robot.joints.wrist_pitch.model_copy(update={"torque_limit_nm": 500.0})
    robot500 = robot.model_copy(update={"joints": robot.joints.model_copy(update={"wrist_pitch": weaker})})
    physics = build_physics(robot500, SceneConfig(soil_cell_size_m=0.05))
    np.testing.assert_allclose(physics.named.model.actuator_forcerange["wrist_pitch"], [-500, 500])
    assert physics.model.hfield_nrow[0] == 61 and physics.model.hfield_ncol[0] == 61
    vmax = np.radians(robot.joints.shoulder.velocity_limit_deg_s)
    np.testing.assert_allclose(physics.named.model.actuator_ctrlrange["shoulder"], [-vmax, vmax])


def test_robot_yaml_defaults_equal_the_model_defaults(mj_model):
    robot = load_robot_config()
    for name, servo in robot.joints.by_actuator().items():
        act = mj_model.actuator(name)
        np.testing.assert_allclose(act.forcerange, [-servo.torque_limit_nm, servo.torque_limit_nm])
        np.testing.assert_allclose(act.ctrlrange[1], servo.velocity_limit_rad_s, rtol=1e-4)
        assert act.gainprm[0] == pytest.approx(servo.kp_nm_per_rad)
        assert act.biasprm[2] == pytest.approx(-servo.kv_nm_s_per_rad)


def test_wrist_pitch_is_the_weakest_joint_as_in_the_thesis():
    robot = load_robot_config()
    limits = {k: v.torque_limit_nm for k, v in robot.joints.by_actuator().items()}
    assert limits["wrist_pitch"] == 1000.0
    assert min(limits, key=limits.get) == "wrist_pitch"


def _load_bucket_generator():
    path = constants.REPO_ROOT / "scripts" / "make_bucket.py"
    spec = importlib.util.spec_from_file_location("make_bucket", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules["make_bucket"] = module  # dataclasses resolve string annotations through sys.modules
    spec.loader.exec_module(module)
    return module


def test_committed_bucket_matches_its_generator(mj_model):
    mb = _load_bucket_generator()
    dims = mb.BucketDims()
    for i, p in enumerate(mb.profile_sites(dims)):
        np.testing.assert_allclose(mj_model.site(f"bucket_profile_{i}").pos, p, atol=1e-5)
    tip = mb.tip_to_body(dims, np.zeros((1, 3)))[0]
    np.testing.assert_allclose(mj_model.site("bucket_tip").pos, tip, atol=1e-9)
    assert mj_model.numeric("bucket_width").data[0] == pytest.approx(dims.inner_width)
    assert mj_model.numeric("bucket_capacity").data[0] == pytest.approx(mb.struck_capacity(dims), rel=1e-5)
    assert mj_model.body("bucket").mass[0] == pytest.approx(dims.mass)
    mesh = mb.bucket_mesh(dims)
    com, _ = mb.inertial(dims, mesh)
    np.testing.assert_allclose(mj_model.body("bucket").ipos, com, atol=1e-5)
    # The committed mesh is the generated one (same bounds).
    import trimesh

    committed = trimesh.load(constants.MODELS_DIR / "t3" / "assets" / "bucket.stl")
    np.testing.assert_allclose(committed.bounds, mesh.bounds, atol=1e-6)


def test_bucket_capacity_and_width_match_the_thesis_bucket():
    mb = _load_bucket_generator()
    dims = mb.BucketDims()
    # §7.1.1 / issue: about 0.30 m wide and 0.02 m^3. The struck area by hand: the rectangle
    # depth x height halved by the strike line, minus the corner the arc cuts off.
    r, depth, height = dims.arc_radius, dims.blade_length + dims.arc_radius, dims.back_height
    by_hand = depth * height / 2 - (r * r - np.pi * r * r / 4)
    assert mb.struck_area(dims) == pytest.approx(by_hand)
    assert 0.018 <= mb.struck_capacity(dims) <= 0.022
    assert dims.inner_width == pytest.approx(0.30)
    # The mesh's plate volume agrees with the profile: polygon area of the side plate x thickness.
    side = mb._extrude_convex(mb.profile_polyline(dims, n_arc=64), 0.0, dims.plate_thickness)
    assert abs(side.volume) == pytest.approx(mb.struck_area(dims) * dims.plate_thickness, rel=2e-3)


def test_scene_builder_uses_pymjcf_and_keeps_unprefixed_names():
    root = build_scene()
    assert isinstance(root, mjcf.RootElement)
    assert root.find("joint", "wrist_pitch_joint") is not None
    assert root.find("site", "bucket_tip") is not None


def test_the_planner_and_map_builder_import_no_simulator():
    """At run time too (the contracts check the import graph): planning, learning and every task's mind
    side load no MuJoCo or Rerun."""
    import subprocess
    import sys

    minds = sorted(".".join(p.relative_to(constants.PACKAGE_ROOT.parent).with_suffix("").parts)
                   for p in (constants.PACKAGE_ROOT / "tasks").glob("*/mind/*.py") if p.name != "__init__.py")
    assert minds, "no task has a mind package"
    code = ("import sys; import excavsim.planning.search, excavsim.planning.anneal, "
            "excavsim.sensing.elevation; import excavsim.learning.predictors, excavsim.learning.adapter, "
            f"excavsim.learning.evaluate, excavsim.learning.figures; import {', '.join(minds)}; "
            "bad = [m for m in ('mujoco', 'dm_control', 'rerun') if m in sys.modules]; print(bad); sys.exit(bool(bad))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
