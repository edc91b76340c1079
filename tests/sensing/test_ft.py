"""The wrist F/T sensor as the robot reads it: the soil's wrench about the bucket tip (§7.1.3, Fig. 103).

References: a known wrench applied to the bucket through ``xfrc_applied`` (MuJoCo applies the force
at the body's centre of mass ``xipos`` and the torque about it), and the soil model's own force on
the bucket during a drag (privileged truth). Noise is off so that differences are the conversion's.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from excavsim import constants
from excavsim.config import ForceSensorConfig, SceneConfig, load_scene_config
from excavsim.errors import ExcavsimError, ModelError
from excavsim.handoff.observation import Observation
from excavsim.robot.extract import arm_from_model
from excavsim.robot.kinematics import PlanarArm
from excavsim.sensing.ft import ForceSensor, FTReading, environment_wrench
from excavsim.world.simulation import Simulation

SURFACE = 0.5  # configs/scene.yaml initial fill [m]


def quiet_scene() -> SceneConfig:
    """The default scene without the truth terms and without F/T noise (as tests/world/test_soil.py)."""
    base = load_scene_config()
    t = {"cohesion_rate_per_decade": 0.0, "brittleness_index": 0.0, "heterogeneity_std": 0.0,
         "ft_force_noise_n": 0.0, "ft_torque_noise_nm": 0.0, "ft_dig_noise_share": 0.0}
    return base.model_copy(update={"truth": base.truth.model_copy(update=t)})


def joint_target(arm: PlanarArm, pose, *, waist=0.0, yaw=0.0, roll=0.0) -> np.ndarray:
    q3, ok = arm.inverse(np.asarray(pose, dtype=float))
    assert ok, pose
    return np.r_[waist, q3, yaw, roll]


def hold(sim: Simulation, target: np.ndarray, *, max_steps: int = 1500, qdot_tol: float = 1e-7) -> Observation:
    """Track ``target`` with the servos until the arm is at rest (max |qdot| below ``qdot_tol`` rad/s)."""
    for _ in range(max_steps):
        obs = sim.track(target)
        if np.abs(obs.qdot).max() < qdot_tol:
            return obs
    raise AssertionError(f"arm did not settle at {target}: max |qdot| = {np.abs(obs.qdot).max():.2e}")


def settle_under(sim: Simulation, wrench: np.ndarray, *, max_steps: int = 1500, qdot_tol: float = 1e-7) -> Observation:
    """Hold the servo set-points (ctrl = 0) with ``wrench`` (6,) on the bucket until at rest.

    MuJoCo is stepped directly: ``Simulation.step`` would overwrite ``xfrc_applied`` with the soil's.
    """
    m, d = sim.model, sim.data
    d.xfrc_applied[m.body(constants.BUCKET_BODY).id] = wrench
    d.ctrl[:] = 0.0
    for _ in range(max_steps):
        mujoco.mj_step(m, d, sim.substeps)
        if np.abs(d.qvel).max() < qdot_tol:
            return sim.observe()
    raise AssertionError(f"arm did not settle under {wrench}: max |qdot| = {np.abs(d.qvel).max():.2e}")


# Poses: (x, z, pitch) of the tip in the arm plane, waist, wrist yaw, wrist roll [m, rad].
POSES = [
    ((2.2, 0.8, math.radians(30)), 0.0, 0.0, 0.0),
    ((1.8, 1.0, math.radians(-20)), 0.4, 0.0, 0.0),
    ((2.0, 0.6, math.radians(50)), -0.3, 0.2, 0.3),
]


@pytest.fixture(scope="module")
def still_sim():
    sim = Simulation(scene=quiet_scene(), seed=0)
    sim.soil_enabled = False
    return sim


@pytest.mark.parametrize(("pose", "waist", "yaw", "roll"), POSES)
def test_reading_equals_a_known_wrench_applied_to_the_bucket(still_sim, pose, waist, yaw, roll):
    """At rest the static balance is exact: the reading is the applied wrench, moment carried to the tip.

    xfrc_applied acts at the bucket's centre of mass c, so its moment about the tip t is
    T + (c - t) x F. The arm droops a few mrad under the load; the sensor sees the drooped pose
    through the measured joint angles. Measured error at rest: ~1e-11 N and N m (round-off); the
    tolerance allows the residual motion of the settling criterion.
    """
    sim = still_sim
    m, d = sim.model, sim.data
    sensor = ForceSensor(m)
    target = joint_target(arm_from_model(m), pose, waist=waist, yaw=yaw, roll=roll)
    hold(sim, target)
    assert abs(d.qpos[m.joint(constants.JOINTS[3]).qposadr[0]]) > 0.1  # wrist pitch really bent
    force = np.array([250.0, -80.0, -300.0])
    torque = np.array([20.0, 40.0, -30.0])
    obs = settle_under(sim, np.r_[force, torque])
    d_before = d.qpos.copy()
    r = sensor.reading(obs)
    np.testing.assert_array_equal(d.qpos, d_before)  # the sensor never writes the world's data

    b = m.body(constants.BUCKET_BODY).id
    tip = m.site(constants.BUCKET_TIP_SITE).id
    t, rot = d.site_xpos[tip], d.site_xmat[tip].reshape(3, 3)
    moment_tip = torque + np.cross(d.xipos[b] - t, force)
    np.testing.assert_allclose(r.force_world, force, atol=1e-3)
    np.testing.assert_allclose(r.torque_world, moment_tip, atol=1e-3)
    np.testing.assert_allclose(r.force_tip, rot.T @ force, atol=1e-3)
    np.testing.assert_allclose(r.torque_tip, rot.T @ moment_tip, atol=1e-3)
    assert r.time == obs.time
    settle_under(sim, np.zeros(6))  # leave the shared sim unloaded


@pytest.mark.parametrize(("pose", "waist", "yaw", "roll"), [POSES[0], POSES[2]])
def test_reading_is_zero_without_an_applied_force(still_sim, pose, waist, yaw, roll):
    """Gravity compensation: the bucket's own weight (28 kg at its centre of mass) is removed."""
    sim = still_sim
    target = joint_target(arm_from_model(sim.model), pose, waist=waist, yaw=yaw, roll=roll)
    obs = hold(sim, target)
    assert np.linalg.norm(obs.ft_force) > 200.0  # the raw reading carries the weight (274.7 N)
    r = ForceSensor(sim.model).reading(obs)
    np.testing.assert_allclose(r.force_world, 0.0, atol=1e-3)
    np.testing.assert_allclose(r.torque_world, 0.0, atol=1e-3)
    np.testing.assert_allclose(r.force_tip, 0.0, atol=1e-3)
    np.testing.assert_allclose(r.torque_tip, 0.0, atol=1e-3)


def test_drag_in_sand_reads_the_wedge_force_backwards_and_out_of_the_blade():
    """A horizontal drag towards the robot at 10 cm depth, 30 deg rake, 5 cm/s, stepped in the full Simulation.

    The reading is the whole soil force: wedge (with surcharge) plus the weight of the load
    gathering in the bucket (up to ~210 N here), plus bearing on the outer face while any remains
    from the vertical entry. Over the drag after the bearing has released (|bearing| < 1 N):

    * the reading equals the soil's total force on the bucket and its moment about the tip
      (measured: 2.1 N and 0.2 N m at most, from the bucket's ignored accelerations);
    * less the load's weight it is the wedge force of eq. 8, along -sin(delta) x_tip - cos(delta) z_tip
      for the testbed sand (delta = 30 deg): backwards along -x_tip and out of the blade along -z_tip
      (measured: within 3.1 N of it, direction within 1.4 deg, for 130-165 N).
    """
    sim = Simulation(scene=quiet_scene(), seed=3)
    m, d = sim.model, sim.data
    arm = arm_from_model(m)
    sensor = ForceSensor(m)
    b, tip = m.body(constants.BUCKET_BODY).id, m.site(constants.BUCKET_TIP_SITE).id
    pitch, z = math.radians(30), SURFACE - 0.1

    def move(p0, p1, speed, extra=0):
        n = max(1, math.ceil(math.dist(p0, p1) / speed / sim.control_dt))
        out = []
        for i in range(n + 1 + extra):
            s = min(i / n, 1.0)
            obs = sim.track(joint_target(arm, (p0[0] + (p1[0] - p0[0]) * s, p0[1] + (p1[1] - p0[1]) * s, pitch)))
            c = sim.contact
            rot, t = d.site_xmat[tip].reshape(3, 3).copy(), d.site_xpos[tip].copy()
            moment_tip = c.torque + np.cross(d.xipos[b] - t, c.force)  # soil torque is about the COM
            out.append((sensor.reading(obs), c.force.copy(), moment_tip, c.cutting_force.copy(),
                        c.load_weight, np.linalg.norm(c.bearing_force), rot))
        return out

    move((2.3, SURFACE + 0.2), (2.3, SURFACE + 0.2), 1.0, extra=100)
    move((2.3, SURFACE + 0.2), (2.3, z), 0.1)
    drag = [row for row in move((2.3, z), (2.0, z), 0.05) if row[5] < 1.0]
    assert len(drag) > 200, len(drag)

    reading = np.array([r.force_world for r, *_ in drag])
    np.testing.assert_allclose(reading, np.array([row[1] for row in drag]), atol=5.0)
    np.testing.assert_allclose(np.array([r.torque_world for r, *_ in drag]), np.array([row[2] for row in drag]),
                               atol=1.0)

    rots = np.array([row[6] for row in drag])
    soil_tip = np.array([r.force_tip - rot.T @ w for (r, _, _, _, w, _, rot) in drag])  # load weight removed
    cut_tip = np.einsum("nji,nj->ni", rots, np.array([row[3] for row in drag]))
    assert np.all(np.linalg.norm(cut_tip, axis=1) > 100.0)
    np.testing.assert_allclose(soil_tip, cut_tip, atol=5.0)
    delta = math.radians(30)  # testbed sand, configs/soils.yaml
    unit = soil_tip / np.linalg.norm(soil_tip, axis=1, keepdims=True)
    np.testing.assert_allclose(unit, np.tile([-math.sin(delta), 0.0, -math.cos(delta)], (len(unit), 1)), atol=0.03)
    assert np.all(soil_tip[:, 0] < 0) and np.all(soil_tip[:, 2] < 0)


def test_sampler_reads_at_the_configured_rate():
    sim = Simulation(scene=quiet_scene(), seed=0)
    sim.soil_enabled = False
    for sensor, expect in ((ForceSensor(sim.model), 10), (ForceSensor.from_config(sim.model), 10),
                           (ForceSensor.from_config(sim.model, ForceSensorConfig(rate_hz=20.0)), 20),
                           (ForceSensor(sim.model, rate_hz=3.0), 3)):
        sim.data.time = 0.0
        obs = [sim.step() for _ in range(round(1.0 / sim.control_dt))]  # 1 s at 100 Hz
        times = [r.time for r in map(sensor.sample, obs) if r is not None]
        assert len(times) == expect, (sensor.rate_hz, times)
        assert times[0] == obs[0].time  # the first call samples
        np.testing.assert_allclose(np.diff(times), 1.0 / expect, atol=sim.control_dt)  # on the observation grid
        sensor.reset()
        assert isinstance(sensor.sample(obs[-1]), FTReading)  # after reset the next call samples
        with pytest.raises(ExcavsimError, match="reset"):
            sensor.sample(obs[0])  # time went backwards without a reset


def test_sampler_tolerates_accumulated_clock_round_off(mj_model):
    """Times summed from 0.01 s steps fall just short of the grid (ten of them make 0.09999999999999999)."""
    sensor = ForceSensor(mj_model)
    t, times = 0.0, []
    for _ in range(100):
        obs = Observation(t, np.zeros(6), np.zeros(6), np.zeros(6), np.zeros(3), np.zeros(3))
        if sensor.sample(obs) is not None:
            times.append(t)
        t += 0.01
    assert len(times) == 10
    np.testing.assert_allclose(times, np.arange(10) * 0.1, atol=1e-12)


@pytest.mark.parametrize("rate", [0.0, -10.0, math.nan, math.inf, "fast", None])
def test_a_bad_rate_is_refused(mj_model, rate):
    with pytest.raises(ExcavsimError, match="rate_hz"):
        ForceSensor(mj_model, rate_hz=rate)


def test_a_wrongly_shaped_observation_is_refused(mj_model):
    sensor = ForceSensor(mj_model)
    good = Observation(0.0, np.zeros(6), np.zeros(6), np.zeros(6), np.zeros(3), np.zeros(3))
    assert isinstance(sensor.reading(good), FTReading)
    for bad, match in ((dict(q=np.zeros(5)), r"q must have shape \(6,\)"),
                       (dict(ft_force=np.zeros((1, 3))), r"ft_force must have shape \(3,\)"),
                       (dict(ft_torque=np.zeros(6)), r"ft_torque must have shape \(3,\)"),
                       (dict(ft_force=np.array([0.0, np.nan, 0.0])), "ft_force must be finite"),
                       (dict(time=math.nan), "time must be finite")):
        obs = Observation(**{**good.__dict__, **bad})
        with pytest.raises(ExcavsimError, match=match):
            sensor.reading(obs)
        with pytest.raises(ExcavsimError, match=match):
            sensor.sample(obs)
    with pytest.raises(ExcavsimError, match="needs an Observation"):
        sensor.reading(object())


def test_a_model_without_the_bucket_is_refused():
    model = mujoco.MjModel.from_xml_string("<mujoco><worldbody><body name='box'><geom size='0.1'/>"
                                           "</body></worldbody></mujoco>")
    with pytest.raises(ModelError, match=r"body 'bucket' not found in the model. Available: \['world', 'box'\]"):
        ForceSensor(model)


def test_environment_wrench_is_vectorized(rng):
    """A batch of (n, ...) inputs gives the rows of n single calls."""
    n = 5
    rots = [np.linalg.qr(rng.normal(size=(n, 3, 3)))[0] for _ in range(2)]
    args = dict(sensor_rot=rots[0], sensor_pos=rng.normal(size=(n, 3)), tip_rot=rots[1],
                tip_pos=rng.normal(size=(n, 3)), com=rng.normal(size=(n, 3)), weight=np.array([0.0, 0.0, -274.68]))
    f, t = rng.normal(size=(n, 3)) * 100, rng.normal(size=(n, 3)) * 10
    batch = environment_wrench(f, t, **args)
    for i in range(n):
        one = environment_wrench(f[i], t[i], **{k: (v[i] if v.ndim > 1 else v) for k, v in args.items()})
        for b_, o in zip(batch, one):
            np.testing.assert_allclose(b_[i], o, rtol=1e-12, atol=1e-12)
