"""DiMaio's bucket-ground model as the world's second truth (DiMaio 1998 §5.1-5.2).

Each component against a hand derivation from the thesis' equations, then the model in the world:
selected from the scene or an episode specification, measured by the F/T, cutting the grid with the
volume account exact.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from excavsim.config import SceneConfig, get_soil, load_scene_config
from excavsim.robot.extract import arm_from_model
from excavsim.world import dimaio, soil_records
from excavsim.world.simulation import Simulation

DT = 0.01
SURFACE = 0.5


def params(**kw) -> np.ndarray:
    """A DIMAIO_PARAMS record with every component off unless given."""
    base = dict(b_t0=0.0, b_n0=0.0, b_a0=0.0, k=0.0, k_a=0.0, t_rt=0.1, t_rn=0.5, t_ra=0.5, shear_s=math.inf,
                eps=0.0, mu=0.0, rho_g=0.0, s_bucket=0.3, width=0.4, v_eps=1e-6)
    base.update(kw)
    return soil_records.filled(soil_records.DIMAIO_PARAMS, **base)


class Planar:
    """Steps :func:`dimaio.planar_step` with a fixed cutting-surface angle."""

    def __init__(self, p: np.ndarray, alpha: float = 0.3):
        self.p = p
        self.state = np.zeros(1, soil_records.DIMAIO_STATE)
        self.out = np.zeros(1, soil_records.DIMAIO_OUT)
        self.t = np.array([math.cos(alpha), math.sin(alpha)])
        self.n = np.array([self.t[1], -self.t[0]])

    def step(self, d_rz=(0.0, 0.0), *, dalpha=0.0, sp=0.1, dp=0.1, load=0.0):
        t, n = self.t, self.n
        dimaio.planar_step(self.p, self.state, t[0], t[1], n[0], n[1], d_rz[0], d_rz[1], dalpha, sp, dp, load, DT,
                           self.out)
        return self.out[0].copy()


def test_viscous_friction_is_eq_5_41_to_5_43():
    """f_b = -R diag(s_p b_t0, s_p b_n0) R^T v, tau_ba = -s_p b_a0 alpha_dot."""
    m = Planar(params(b_t0=3.0e4, b_n0=1.0e4, b_a0=500.0), alpha=0.4)
    v = np.array([-0.2, -0.05])
    o = m.step(v * DT, dalpha=0.3 * DT, sp=0.12)
    c, s = math.cos(0.4), math.sin(0.4)
    rot = np.array([[c, s], [s, -c]])  # columns t and n (n = t turned by -90 deg, the tip frame's z_t)
    expected = -rot @ np.diag([0.12 * 3.0e4, 0.12 * 1.0e4]) @ rot.T @ v
    np.testing.assert_allclose(o["force_rz"], expected, rtol=1e-12)
    np.testing.assert_allclose(o["viscous_tn"], [-0.12 * 3.0e4 * (v @ rot[:, 0]), -0.12 * 1.0e4 * (v @ rot[:, 1])],
                               rtol=1e-12)
    assert o["torque_pure"] == pytest.approx(-0.12 * 500.0 * 0.3, rel=1e-12)


def test_stiffness_about_a_lagging_centre_matches_the_hand_recursion():
    """Eqs. 5.44 and 5.46 discretized (backward Euler, a = T / (T + T_s)): the edge moving d per step
    along t from a centre at the edge gives e_m = -d a (1 - a^m) / (1 - a), f_kt = k e_m, which tends
    to -k v T (the steady force of eq. 5.57's k T s / (T s + 1) term)."""
    k, t_rt, v = 1.0e5, 0.1, 0.2
    m = Planar(params(k=k, t_rt=t_rt))
    a = t_rt / (t_rt + DT)
    d = v * DT
    forces = [m.step(d * m.t)["stiffness_tn"][0] for _ in range(200)]  # moves +d along t
    steps = np.arange(1, 201)
    np.testing.assert_allclose(forces, -k * d * a * (1 - a ** steps) / (1 - a), rtol=1e-12)
    assert forces[-1] == pytest.approx(-k * v * t_rt, rel=1e-6)
    # no normal force from a tangential motion, and the centre relaxes back when the edge stops
    assert m.out[0]["stiffness_tn"][1] == pytest.approx(0.0, abs=1e-9)
    held = [m.step()["stiffness_tn"][0] for _ in range(3)]
    np.testing.assert_allclose(held, forces[-1] * a ** np.arange(1, 4), rtol=1e-12)


def test_normal_stiffness_uses_its_own_time_constant():
    k, t_rn = 2.0e4, 0.5
    m = Planar(params(k=k, t_rn=t_rn))
    a = t_rn / (t_rn + DT)
    o = m.step(0.01 * m.n)
    assert o["stiffness_tn"][1] == pytest.approx(-k * 0.01 * a, rel=1e-12)
    assert o["stiffness_tn"][0] == pytest.approx(0.0, abs=1e-9)


def test_shear_failure_when_the_normal_stiffness_force_reaches_s_w_dp():
    """Eq. 5.45: the step at which |f_kn| first reaches S w d_p relieves the stiffness (centre reset)."""
    k, t_rn, s, w, dp = 1.0e5, 0.5, 2.0e4, 0.4, 0.1
    m = Planar(params(k=k, t_rn=t_rn, shear_s=s, width=w))
    a = t_rn / (t_rn + DT)
    d = 0.002
    threshold = s * w * dp  # 800 N
    e = 0.0
    for i in range(100):
        e = a * (e - d)  # the hand recursion, pushing along +n
        o = m.step(d * m.n, dp=dp)
        assert o["threshold_n"] == pytest.approx(threshold)
        if abs(k * e) >= threshold:
            assert o["sheared"] == 1.0 and o["stiffness_tn"][1] == 0.0
            break
        assert o["sheared"] == 0.0 and o["stiffness_tn"][1] == pytest.approx(k * e, rel=1e-12)
    else:
        pytest.fail("never sheared")
    assert i == 4  # 200, 398, 594, 790, 984 N (a = 0.98): the fifth step shears
    # after the shear the centre is at the edge again: the next push starts from zero
    assert m.step(d * m.n, dp=dp)["stiffness_tn"][1] == pytest.approx(-k * d * a, rel=1e-12)


def test_coulomb_friction_opposes_the_tangential_motion_with_mu_times_the_normal_force():
    """Eq. 5.49: f_ct = -mu |f_bn + f_kn + f_ln| v_t / |v_t|, whichever way the edge slides."""
    mu, b_n0 = 0.6, 1.0e4
    for sense in (+1.0, -1.0):
        m = Planar(params(mu=mu, b_n0=b_n0, rho_g=2000 * 9.81, eps=1.0e4), alpha=0.3)
        move = sense * 0.1 * DT * m.t + 0.05 * DT * m.n
        o = m.step(move, load=0.02)
        f_bn = -0.1 * b_n0 * 0.05
        f_ln = np.array([1.0e4 * 0.02, -2000 * 9.81 * 0.02]) @ m.n
        assert o["coulomb_t"] == pytest.approx(-sense * mu * abs(f_bn + f_ln), rel=1e-12)
        assert np.sign(o["coulomb_t"]) == -sense


def test_the_load_is_accumulation_and_weight_at_the_centre_of_the_cutting_surface():
    """Eq. 5.47: f_lr = eps V, f_lz = -rho g V, acting s_bucket / 2 behind the edge: its moment about the
    edge is (s/2) times the load's normal component (the thesis' tau_la), with the sign of r x f."""
    m = Planar(params(eps=1.0e4, rho_g=2000 * 9.81, s_bucket=0.3), alpha=0.5)
    o = m.step(load=0.03)
    f = np.array([1.0e4 * 0.03, -2000 * 9.81 * 0.03])
    np.testing.assert_allclose(o["load_rz"], f, rtol=1e-12)
    lever = -0.15 * m.t
    assert o["torque_tip"] == pytest.approx(lever[0] * f[1] - lever[1] * f[0], rel=1e-12)
    assert abs(o["torque_tip"]) == pytest.approx(0.15 * abs(f @ m.n), rel=1e-12)
    # out of the soil only the weight acts
    out_of_soil = m.step(sp=0.0, dp=0.0, load=0.03)
    np.testing.assert_allclose(out_of_soil["force_rz"], [0.0, f[1]], rtol=1e-12)


def test_the_total_is_the_sum_of_the_components():
    m = Planar(params(b_t0=1e4, b_n0=5e3, k=2e4, mu=0.5, eps=1e4, rho_g=2e4), alpha=-0.2)
    for _ in range(20):
        o = m.step((-0.002, -0.001), load=0.01)
    t, n = m.t, m.n
    total = ((o["viscous_tn"][0] + o["stiffness_tn"][0] + o["coulomb_t"]) * t
             + (o["viscous_tn"][1] + o["stiffness_tn"][1]) * n + o["load_rz"])
    np.testing.assert_allclose(o["force_rz"], total, rtol=1e-12)
    np.testing.assert_allclose(o["force_tn"], [o["force_rz"] @ t, o["force_rz"] @ n], rtol=1e-12)


# -- in the world --------------------------------------------------------------------------------------

def dimaio_scene(**truth) -> SceneConfig:
    base = load_scene_config()
    t = {"model": "dimaio", "ft_force_noise_n": 0.0, "ft_torque_noise_nm": 0.0}
    t.update(truth)
    return base.model_copy(update={"truth": base.truth.model_copy(update=t)})


class Driver:
    """Moves the arm kinematically along tip poses and steps only the soil model."""

    def __init__(self, sim: Simulation):
        self.sim = sim
        self.arm = arm_from_model(sim.model)

    def place(self, pose, waist: float = 0.0):
        m, d = self.sim.model, self.sim.data
        q3, ok = self.arm.inverse(np.asarray(pose, float))
        assert ok, pose
        d.qpos[:6] = np.r_[waist, q3, 0.0, 0.0]
        mujoco.mj_forward(m, d)
        d.time += self.sim.control_dt
        return self.sim.soil.step(d, self.sim.control_dt)

    def line(self, start, end, speed: float, waist: float = 0.0):
        start, end = np.asarray(start, float), np.asarray(end, float)
        n = max(1, int(np.ceil(np.linalg.norm(end[:2] - start[:2]) / speed / self.sim.control_dt)))
        return [self.place(start + (end - start) * (i / n), waist) for i in range(n + 1)]


def test_the_wedge_stays_the_default_and_a_spec_selects_dimaio():
    assert SceneConfig(soil_cell_size_m=0.025).truth.model == "wedge"
    assert load_scene_config().truth.model == "wedge"
    assert Simulation(seed=0).soil.dimaio is None
    from excavsim.loop.scenario import EpisodeSpec, resolve

    spec = EpisodeSpec(name="d", scene={"truth": {"model": "dimaio"}})
    assert resolve(spec).scene.truth.model == "dimaio"
    assert get_soil("testbed_sand").dimaio is not None


def test_a_horizontal_drag_in_the_world_is_the_planar_model():
    """In the soil box, a drag at constant depth and pitch: the kernel's plane quantities are the
    drag's (speed along t, penetration = depth), its viscous force is -s_p b_t0 v_t, and the
    wrench applied to the bucket is the model's total in the world frame."""
    sim = Simulation(scene=dimaio_scene(), seed=3)
    drv = Driver(sim)
    pitch, depth, speed = math.radians(30), 0.08, 0.1
    drv.line((2.3, SURFACE + 0.2, pitch), (2.3, SURFACE - depth, pitch), 0.1)
    contacts = drv.line((2.3, SURFACE - depth, pitch), (1.9, SURFACE - depth, pitch), speed)
    c = contacts[-1]  # the step whose DIMAIO_OUT the model still holds
    o = sim.soil.dimaio.out[0]
    dm = get_soil("testbed_sand").dimaio
    t = np.array([-math.cos(pitch), -math.sin(pitch)])  # x_t in (r, z)
    v_t = speed * t[0] * -1.0  # the edge moves towards the waist (-r)
    assert o["v_t"] == pytest.approx(v_t, rel=0.02)
    assert o["sp_m"] == pytest.approx(depth, abs=0.01)
    assert o["viscous_tn"][0] == pytest.approx(-o["sp_m"] * dm.viscous_tangential_n_s_m2 * o["v_t"], rel=1e-9)
    np.testing.assert_allclose(c.force[[0, 2]], o["force_rz"], rtol=1e-9)  # waist 0: r is world x
    assert c.force[1] == pytest.approx(0.0, abs=1e-9)
    np.testing.assert_allclose(c.force, c.cutting_force + c.load_weight + np.array([o["load_rz"][0], 0, 0]),
                               rtol=1e-9, atol=1e-9)
    assert np.all(c.bearing_force == 0.0) and np.all(c.rock_force == 0.0)
    assert sim.soil.load > 0.005 and any(x.cut_volume_m3 > 0 for x in contacts)


def test_volume_is_exact_through_a_dig_a_dump_and_settlement_with_the_dimaio_truth():
    sim = Simulation(scene=dimaio_scene(), seed=4)
    soil, drv = sim.soil, Driver(sim)
    v0 = soil.volumes().total
    pitch = math.radians(30)
    drv.line((2.3, SURFACE + 0.2, pitch), (2.3, SURFACE - 0.15, pitch), 0.1)
    drv.line((2.3, SURFACE - 0.15, pitch), (1.6, SURFACE - 0.15, pitch), 0.15)  # fills and spills
    assert soil.load == pytest.approx(soil.heaped_capacity)
    assert soil.spoil == 0.0 and soil.volumes().box < v0
    drv.line((1.6, SURFACE - 0.15, pitch), (1.6, 1.1, math.radians(-30)), 0.2)
    for p in np.linspace(-30, 100, 60):
        drv.place((1.7, 1.3, math.radians(p)), waist=math.radians(40))
    assert soil.load == pytest.approx(0.0, abs=1e-15)
    soil.settle_all()
    assert soil.volumes().total == pytest.approx(v0, rel=1e-12)


def test_the_ft_sensor_measures_the_dimaio_force_in_an_episode():
    """A whole one-dig episode on the DiMaio truth: it digs, the volume balance holds, and the
    executor's F/T trace carries forces of the model's size (hundreds of newtons)."""
    from excavsim.handoff.episode import EpisodeObserver
    from excavsim.loop.scenario import EpisodeSpec, run_spec

    class Records(EpisodeObserver):
        records: list = []

        def dug(self, index, record, metrics):
            self.records.append(record)

    spec = EpisodeSpec(name="dimaio", goal="small", seed=2, dig_budget=1, scene={"truth": {"model": "dimaio"}})
    obs = Records()
    result = run_spec(spec, observer=obs)
    assert abs(result.volume_change_m3) < 1e-12
    rec = obs.records[0]
    peak = max(float(np.hypot(f[0], f[2])) for _, f in rec.ft)
    assert rec.outcome.startswith("completed") and 100.0 < peak < 5000.0
