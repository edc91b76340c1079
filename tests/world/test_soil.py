"""The world's soil: grid layout, bucket geometry, cutting, filling, spilling, dumping, forces.

Most tests drive the bucket kinematically (joint angles set from IK, velocities by finite
difference, ``mj_forward``) and call the soil model directly, as the thesis' experiments made the
bucket follow a prescribed trajectory (§5.1.3). The end-to-end tests step the full Simulation.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from excavsim import constants
from excavsim.config import SceneConfig, get_soil, load_scene_config
from excavsim.mechanics.bearing import bearing_factors
from excavsim.mechanics.wedge import wedge_force
from excavsim.robot.extract import arm_from_model
from excavsim.world import soil_records
from excavsim.world.bucket import BucketGeometry
from excavsim.world.simulation import Simulation
from excavsim.world.soil import SoilModel

SURFACE = 0.5  # configs/scene.yaml initial fill [m]


def quiet_scene(**truth) -> SceneConfig:
    """The default scene with the truth terms switched off (or set as given)."""
    base = load_scene_config()
    t = {"cohesion_rate_per_decade": 0.0, "brittleness_index": 0.0, "heterogeneity_std": 0.0,
         "ft_force_noise_n": 0.0, "ft_torque_noise_nm": 0.0}
    t.update(truth)
    return base.model_copy(update={"truth": base.truth.model_copy(update=t)})


class Driver:
    """Moves the arm kinematically along tip poses and steps only the soil model."""

    def __init__(self, sim: Simulation):
        self.sim = sim
        self.arm = arm_from_model(sim.model)
        self.q_prev: np.ndarray | None = None
        self.loads_before: list[float] = []  # the bucket's load before each step [m^3]

    def place(self, pose, waist: float = 0.0, dt: float | None = None):
        m, d = self.sim.model, self.sim.data
        q3, ok = self.arm.inverse(np.asarray(pose, float))
        assert ok, pose
        q = np.r_[waist, q3, 0.0, 0.0]
        dt = dt or self.sim.control_dt
        d.qpos[:6] = q
        d.qvel[:6] = 0.0 if self.q_prev is None else (q - self.q_prev) / dt
        self.q_prev = q
        mujoco.mj_forward(m, d)
        d.time += dt
        self.loads_before.append(self.sim.soil.load)
        return self.sim.soil.step(d, dt)

    def line(self, start, end, speed: float, waist: float = 0.0):
        start, end = np.asarray(start, float), np.asarray(end, float)
        n = max(1, int(np.ceil(np.linalg.norm(end[:2] - start[:2]) / speed / self.sim.control_dt)))
        return [self.place(start + (end - start) * (i / n), waist) for i in range(n + 1)]

    def drag(self, x0: float, x1: float, depth: float, rake: float, speed: float = 0.1, above: float = 0.2):
        """Lower the edge vertically at x0 to ``depth`` below the flat surface, then drag it to x1."""
        z = SURFACE - depth
        self.place((x0, SURFACE + above, rake))
        self.line((x0, SURFACE + above, rake), (x0, z, rake), 0.1)
        return self.line((x0, z, rake), (x1, z, rake), speed)


@pytest.fixture(scope="module")
def quiet_sim():
    return Simulation(scene=quiet_scene(), seed=1)


def test_grid_matches_the_mujoco_hfield_layout():
    """A raised sample is seen by mj_ray where SoilGrid says it is (row = y, col = x)."""
    sim = Simulation(scene=quiet_scene(), seed=0)
    g = sim.soil.grid
    g.heights[10, 100] = 0.9
    g.write_hfield(sim.model)
    mujoco.mj_forward(sim.model, sim.data)
    x, y = g.xy(10, 100)
    geom = np.zeros(1, np.int32)
    group = np.array([1, 0, 0, 0, 0, 0], np.uint8)  # soil geom only (group 0)
    dist = mujoco.mj_ray(sim.model, sim.data, np.array([x, y, 2.0]), np.array([0, 0, -1.0]), group, 1, -1, geom)
    assert geom[0] == sim.model.geom(constants.SOIL_GEOM).id
    assert 2.0 - dist == pytest.approx(0.9, abs=1e-6)  # hfield_data is float32
    assert g.surface_z(x, y) == pytest.approx(0.9)
    assert g.surface_z(x + g.cell / 2, y) == pytest.approx((0.9 + SURFACE) / 2)
    assert g.surface_z(g.x0 - 0.1, y) == -np.inf


def test_deposit_conserves_volume_and_reports_what_falls_off_the_grid():
    sim = Simulation(scene=quiet_scene(), seed=0)
    g = sim.soil.grid
    v0 = g.volume()
    lost = g.deposit(np.array([2.0, g.x1 + 1.0, g.x1]), np.array([0.0, 0.0, 0.0]), np.array([0.01, 0.02, 0.004]),
                     radius_m=0.1)
    assert lost > 0.02  # the whole second pile and part of the third (at the wall)
    assert g.volume() + lost == pytest.approx(v0 + 0.034, abs=1e-15)


def test_bucket_geometry_from_the_model(mj_model):
    b = BucketGeometry.from_model(mj_model)
    tip = mj_model.site(constants.BUCKET_TIP_SITE)
    np.testing.assert_allclose(b.edge.mean(axis=0), tip.pos, atol=1e-12)  # edge samples centred on the tip
    assert b.edge[:, 1].max() - b.edge[:, 1].min() == pytest.approx(b.width * (1 - 1 / len(b.edge)))
    np.testing.assert_allclose(np.linalg.norm(b.normals, axis=1), 1.0)
    assert b.areas.sum() * len(b.edge) == pytest.approx(b.width * b.arc_length[-1], rel=0.05)
    # Tip frame: x_t = -z_body, z_t = -x_body. The blade's outer normal is -z_t = +x_body; the mouth
    # opens along (x_t + z_t)/sqrt(2) for this bucket (depth = back height = 0.38 m).
    np.testing.assert_allclose(b.normals[1], [1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(b.mouth_normal, np.array([-1, 0, -1]) / math.sqrt(2), atol=1e-12)
    # Load centroid: inside the profile (between blade and back) and above the blade.
    assert 0.04 < b.load_centroid[0] < 0.42 and -0.38 < b.load_centroid[2] < 0.0


def test_bearing_factors_match_tabulated_values():
    # Standard tables (e.g. Vesic 1973): phi = 30 deg -> N_c 30.14, N_q 18.40, N_gamma 22.40.
    n_c, n_q, n_g = bearing_factors(math.radians(30))
    assert (n_c, n_q, n_g) == pytest.approx((30.14, 18.40, 22.40), abs=0.01)
    assert bearing_factors(0.0)[0] == pytest.approx(2 + math.pi)


@pytest.mark.parametrize("load_surcharge", [False, True])
@pytest.mark.parametrize("depth", [0.05, 0.10, 0.15])
def test_horizontal_drag_matches_the_wedge_model(depth, load_surcharge):
    """Quiet soil (no truth terms): steady force equals eq. 8 at the rake of the drag, in direction eq. 8,
    plus (with ``load_surcharge``) the bearing share ``V min(V / C, 1)`` of the load as surcharge (eq. 7)."""
    base = quiet_scene()
    scene = base.model_copy(update={"bucket": base.bucket.model_copy(update={"load_surcharge": load_surcharge})})
    sim = Simulation(scene=scene, seed=2)
    rake = math.radians(30)
    driver = Driver(sim)
    contacts = driver.drag(2.3, 1.9, depth, rake)
    half = len(contacts) // 2
    steady = contacts[half:]
    f = np.array([c.cutting_force for c in steady])
    soil = sim.soil.soil
    # Nothing heaps ahead (the bucket is far from full); the inertial term of the dynamic earthmoving
    # equation at the drag's 0.1 m/s is under 1 %.
    from excavsim.mechanics.wedge import surcharge_force
    from excavsim.mechanics.wedge_inertia import inertial_force
    width = sim.soil.bucket.width
    expect = float(wedge_force(depth, rake, soil, width) + inertial_force(depth, rake, 0.1, soil, width))
    if load_surcharge:
        load = np.array(driver.loads_before[-len(steady):])
        cap = sim.soil.heaped_capacity
        assert load.max() < cap  # not full: nothing spills ahead
        expect = expect + surcharge_force(load * load / cap, rake, soil)
    mag = np.linalg.norm(f, axis=1)
    np.testing.assert_allclose(mag, expect, rtol=0.01)
    # Direction: backward (+x, away from the robot) and down at pi/2 - rho - delta from horizontal.
    angle = np.arctan2(-f[:, 2], f[:, 0])
    np.testing.assert_allclose(angle, math.pi / 2 - rake - soil.delta, atol=0.01)


def test_load_surcharge_share_grows_with_the_fill():
    """kernels.load_surcharge_volume by hand: V min(V / C, 1)."""
    from excavsim.world.kernels import load_surcharge_volume
    assert load_surcharge_volume(0.0, 0.025) == 0.0
    assert load_surcharge_volume(0.005, 0.025) == pytest.approx(0.001)  # a fifth full: a fifth of 5 l bears
    assert load_surcharge_volume(0.0125, 0.025) == pytest.approx(0.00625)
    assert load_surcharge_volume(0.025, 0.025) == pytest.approx(0.025)  # full: all of it (Fig. 57)
    assert load_surcharge_volume(0.03, 0.025) == pytest.approx(0.03)


def test_drag_forces_are_hundreds_of_newtons_and_grow_with_depth():
    """Fig. 59 band: a 0.3 m bucket at 5, 10, 15 cm in the testbed sand, with the truth terms on."""
    peaks = []
    for depth in (0.05, 0.10, 0.15):
        contacts = Driver(Simulation(seed=3)).drag(2.3, 2.0, depth, math.radians(30))
        peaks.append(np.mean([np.linalg.norm(c.cutting_force) for c in contacts[len(contacts) // 3:]]))
    assert peaks[0] < peaks[1] < peaks[2]
    assert 15 < peaks[0] and peaks[2] < 2000, peaks  # eq. 8: 26 N at 5 cm; the failure cycle averages below it
    assert peaks[1] > 80, peaks  # eq. 8: 102 N at 10 cm


def test_cutting_force_acts_only_while_the_edge_moves_into_soil():
    sim = Simulation(scene=quiet_scene(), seed=4)
    drv = Driver(sim)
    z, rake = SURFACE - 0.1, math.radians(30)
    moving = drv.drag(2.3, 2.1, 0.1, rake)[-1]
    held = [drv.place((2.1, z, rake)) for _ in range(20)][-1]
    backed = drv.line((2.1, z, rake), (2.15, z, rake), 0.1)[-1]
    assert np.linalg.norm(moving.cutting_force) > 100
    # Stalled: the elastic wedge keeps its load (no chatter when the arm stops against the soil).
    assert np.linalg.norm(held.cutting_force) == pytest.approx(np.linalg.norm(moving.cutting_force), rel=0.05)
    assert np.linalg.norm(backed.cutting_force) == 0.0


def test_speed_increases_the_cutting_force():
    """Fig. 63: the static model misses the speed effect; the dynamic earthmoving equation adds it."""
    forces = []
    for speed in (0.05, 1.0):
        sim = Simulation(scene=quiet_scene(), seed=5)
        c = Driver(sim).drag(2.3, 2.0, 0.1, math.radians(30), speed)
        forces.append(np.mean([c_.wedge_failure_force_n for c_ in c[len(c) // 2:]]))
    assert forces[1] > 1.2 * forces[0]


def test_sawtooth_rises_and_drops():
    sim = Simulation(scene=quiet_scene(brittleness_index=0.3), seed=6)
    contacts = Driver(sim).drag(2.3, 1.9, 0.1, math.radians(30), 0.05)
    f = np.array([np.linalg.norm(c.cutting_force) for c in contacts])
    drops = np.diff(f) < -0.15 * f[1:]
    assert 2 <= drops.sum() <= 40  # successive failure surfaces shear a few cm apart


def test_bearing_when_the_rake_is_below_the_approach_angle():
    """Fig. 19: penetrating at alpha with rake < alpha presses the bottom into the soil."""
    results = {}
    for name, rake_deg in (("clear", 50.0), ("bearing", 20.0)):
        sim = Simulation(scene=quiet_scene(), seed=7)
        drv = Driver(sim)
        alpha = math.radians(40)
        rake = math.radians(rake_deg)
        start = np.array([2.3, SURFACE, rake])
        end = start + np.array([-0.2 * math.cos(alpha), -0.2 * math.sin(alpha), 0.0])
        drv.place(start + [0, 0.1, 0])
        drv.line(start + [0, 0.1, 0], start, 0.1)
        c = drv.line(start, end, 0.1)
        results[name] = max(np.linalg.norm(x.bearing_force) for x in c)
    assert results["bearing"] > 5 * max(results["clear"], 1.0), results


def test_full_bucket_spills_ahead_and_conserves_volume():
    sim = Simulation(scene=quiet_scene(), seed=8)
    soil = sim.soil
    drv = Driver(sim)
    v0 = soil.volumes().total
    c = drv.drag(2.35, 1.6, 0.15, math.radians(30), above=0.15)
    assert soil.load == pytest.approx(soil.heaped_capacity)
    assert sum(x.spilled_volume_m3 for x in c) > 0.005
    soil.settle_all()
    assert soil.volumes().total == pytest.approx(v0, rel=1e-12)


def test_a_spill_is_spread_over_the_failure_wedge_not_stacked_in_one_row():
    """Eq. 7 spreads the displaced soil uniformly over the wedge: while a full bucket keeps cutting,
    the soil it cannot take lies over the wedge's length ahead of the edge. Stacked in the row just
    ahead (as before), 1 cm of spill per step would stand as a column tens of cm high."""
    sim = Simulation(scene=quiet_scene(), seed=8)
    grid = sim.soil.grid
    drv = Driver(sim)
    h0 = grid.heights.copy()
    c = drv.drag(2.35, 1.6, 0.15, math.radians(30), above=0.15)
    spilled = sum(x.spilled_volume_m3 for x in c)
    assert spilled > 0.005
    rise = grid.heights - h0
    ahead = rise > 1e-9
    # the spill lies on many rows of cells along the drag, not in a few
    assert len(np.unique(np.nonzero(ahead)[1])) >= 8
    # the highest pile is within a few times what a uniform layer over the wedge gives: one step's
    # wedge at 15 cm depth and a 30 deg rake is d (cot 30 + cot beta), about half a metre long
    assert rise.max() < 0.15

def test_dump_empties_the_bucket_where_it_falls():
    sim = Simulation(scene=quiet_scene(), seed=9)
    soil = sim.soil
    drv = Driver(sim)
    soil.load = soil.heaped_capacity
    soil.grid.heights -= soil.load / soil.grid.cell_area / soil.grid.heights.size  # keep the total unchanged
    v0 = soil.volumes().total
    carry = drv.place((1.6, 1.1, math.radians(-30)), waist=math.radians(40))
    assert soil.load == pytest.approx(soil.heaped_capacity)  # mouth up: the load stays
    tilt = [drv.place((1.7, 1.3, math.radians(p)), waist=math.radians(40)) for p in np.linspace(-30, 100, 60)]
    assert carry.poured_volume_m3 == 0.0
    assert soil.load == pytest.approx(0.0, abs=1e-15)
    assert sum(t.poured_volume_m3 for t in tilt) == pytest.approx(soil.heaped_capacity)
    soil.settle_all()
    assert soil.volumes().total == pytest.approx(v0, rel=1e-12)
    assert soil.spoil == 0.0  # the pile landed inside the box
    # The pile is below the bucket's lip, on the spoil side (y > 0 at waist +40 deg).
    g = soil.grid
    rows, cols = np.nonzero(g.heights > g.heights.mean() + 0.02)
    assert len(rows) > 0 and g.xy(rows, cols)[1].mean() > 0.5


def test_load_weight_and_soil_wrench_are_consistent():
    """The applied wrench is the sum of its parts, and the load's weight is gamma g V downwards."""
    sim = Simulation(scene=quiet_scene(), seed=10)
    drv = Driver(sim)
    sim.soil.load = 0.01
    c = drv.place((1.6, 1.1, math.radians(-30)))
    np.testing.assert_allclose(c.load_weight, [0, 0, -2000 * 0.01 * 9.81], rtol=1e-12)
    np.testing.assert_allclose(c.force, c.cutting_force + c.bearing_force + c.load_weight + c.rock_force)


def test_every_part_of_the_wrench_reaches_the_total_while_digging_into_a_rock():
    """Cutting, bearing (rake below the approach), a rock on the path and the load: at every step
    the total force is the sum of the parts the kernel writes, to round-off."""
    sim = Simulation(scene=quiet_scene(rocks=1), seed=12)
    soil = sim.soil
    soil.rocks[:] = [[2.0, 0.0, SURFACE - 0.1, 0.06]]
    soil.load = 0.005
    contacts = Driver(sim).drag(2.3, 1.95, 0.1, math.radians(20), above=0.1)
    parts = np.array([[c.cutting_force, c.bearing_force, c.rock_force, c.load_weight] for c in contacts])
    assert (np.linalg.norm(parts, axis=2) > 1.0).any(axis=0).all()  # each part acts at some step
    np.testing.assert_allclose([c.force for c in contacts], parts.sum(axis=1), rtol=0, atol=1e-9)


def test_soil_contact_reads_the_fields_of_the_kernel_output_record():
    sim = Simulation(scene=quiet_scene(), seed=10)
    sim.soil.load = 0.01
    contacts = Driver(sim).drag(2.3, 2.1, 0.1, math.radians(20), above=0.1)
    c = max(contacts, key=lambda c: c.cut_volume_m3)
    rec = c.record[0]
    for prop, field in (("depth_m", "depth_m"), ("rake_rad", "rake_rad"), ("cutting_speed_m_s", "cutting_speed_m_s"),
                        ("wedge_failure_force_n", "wedge_failure_force_n"), ("cut_volume_m3", "cut_volume_m3"),
                        ("max_penetration_m", "max_penetration_m"), ("cutting_force", "cutting_force_n"),
                        ("bearing_force", "bearing_force_n"), ("rock_force", "rock_force_n"), ("force", "force_n"),
                        ("torque", "torque_nm")):
        np.testing.assert_array_equal(getattr(c, prop), rec[field], err_msg=prop)
    assert c.load_weight[2] == rec["load_weight_z_n"] < 0
    assert 0.05 < c.depth_m < 0.15 and c.max_penetration_m > 0 and c.cut_volume_m3 > 0  # a live cut, not zeros
    assert c.cut_volume_m3 == rec["taken_volume_m3"]  # the bucket is far from full: all of it entered


def test_the_kernel_writes_every_field_of_its_output_record_each_step():
    """No field of a step's snapshot is left over from the step before."""
    sim = Simulation(scene=quiet_scene(), seed=10)
    soil = sim.soil
    drv = Driver(sim)
    for pose in ((2.3, SURFACE + 0.1, 0.5), (2.3, SURFACE - 0.05, 0.5)):  # in the air, then in the soil
        soil._out_f8[:] = np.nan  # every float field
        soil._window[:] = -7
        rec = drv.place(pose).record[0]
        for field in soil_records.OUT.names:
            assert np.isfinite(rec[field]).all() and (rec[field] != -7).all(), field


def test_a_parameter_changed_in_the_record_changes_the_next_step_as_the_physics_says():
    """The soil's density in the kernel's parameter record is the mass the dynamic earthmoving equation
    accelerates: doubled, it doubles the inertial part of the wedge's failure force and nothing else."""
    contacts = []
    for factor in (1.0, 2.0):
        sim = Simulation(scene=quiet_scene(), seed=5)
        drv = Driver(sim)
        drv.drag(2.3, 2.2, 0.1, math.radians(30), 0.1)
        sim.soil.params["density_kg_m3"] *= factor
        contacts.append(drv.place((2.18, SURFACE - 0.1, math.radians(30))))
    base, heavy = contacts
    inertia = base.inertial_force_n
    assert base.cutting_speed_m_s == heavy.cutting_speed_m_s > 0.05 and base.depth_m == heavy.depth_m > 0.05
    assert inertia > 0 and heavy.inertial_force_n == pytest.approx(2 * inertia, rel=1e-12)
    assert heavy.wedge_failure_force_n == pytest.approx(base.wedge_failure_force_n + inertia, rel=1e-12)


def test_a_record_is_built_from_every_one_of_its_fields():
    g = soil_records.filled(soil_records.GRID, x0_m=-1.0, y0_m=-2.0, cell_m=0.025, z0_m=0.1)
    assert g.shape == (1,) and g["cell_m"][0] == 0.025
    with pytest.raises(TypeError, match=r"missing \['z0_m'\], unknown \['z_m'\]"):
        soil_records.filled(soil_records.GRID, x0_m=-1.0, y0_m=-2.0, cell_m=0.025, z_m=0.1)


def test_ft_sensor_reads_the_applied_soil_force():
    """Sign and frame: MuJoCo's force sensor at ft_mount gives the force the wrist exerts on the bucket
    subtree, in the ft_mount frame. At rest, wrist force + soil force + bucket weight = 0, so after
    taring the bucket's weight the reading is -R^T F_soil (R the ft_mount orientation)."""
    sim = Simulation(scene=quiet_scene(), seed=11)
    sim.soil_enabled = False
    m, d = sim.model, sim.data
    bucket = sim.soil.bucket.body_id
    mass = m.body_subtreemass[bucket]
    site = m.site(constants.FT_SITE).id
    hold = sim.observe().q
    for _ in range(200):
        sim.track(hold)
    f_soil = np.array([300.0, -40.0, -200.0])
    d.xfrc_applied[bucket, :3] = f_soil
    for _ in range(300):
        mujoco.mj_step(m, d, sim.substeps)
        sim.data.ctrl[:] = 0.0
    assert np.abs(d.qvel).max() < 1e-4
    rot = d.site_xmat[site].reshape(3, 3)
    reading = sim.observe().ft_force  # noise off in quiet_scene
    tare = -rot.T @ (mass * m.opt.gravity)
    np.testing.assert_allclose(reading - tare, -rot.T @ f_soil, atol=0.05)


def test_soil_params_from_presets_load():
    for name in ("testbed_sand", "sandy_loam", "dry_sand", "heavy_clay", "lean_clay"):
        soil = get_soil(name)
        assert soil.tool_friction_angle_deg == soil.friction_angle_deg  # delta = phi (§5.1.1)


def test_rocks_push_the_edge_back(tmp_path):
    sim = Simulation(scene=quiet_scene(rocks=1), seed=12)
    soil = sim.soil
    drv = Driver(sim)
    z, rake = SURFACE - 0.1, math.radians(30)
    soil.rocks[:] = [[2.0, 0.0, z, 0.06]]  # a rock right on the drag path
    c = drv.drag(2.3, 1.95, 0.1, rake)
    assert max(np.linalg.norm(x.rock_force) for x in c) > 1000


def test_simulation_is_deterministic_for_a_seed():
    def run(seed):
        sim = Simulation(seed=seed)
        arm = arm_from_model(sim.model)
        obs = []
        for i in range(150):
            pose = np.array([2.2 - 0.002 * i, 0.62 - 0.0015 * i, math.radians(45)])
            q, _ = arm.inverse(pose)
            obs.append(sim.track(np.r_[0.0, q, 0.0, 0.0]))
        return sim.truth.heights, np.array([o.ft_force for o in obs]), sim.soil.load

    h1, f1, l1 = run(7)
    h2, f2, l2 = run(7)
    h3, f3, _ = run(8)
    np.testing.assert_array_equal(h1, h2)
    np.testing.assert_array_equal(f1, f2)
    assert l1 == l2 and l1 > 0
    assert not np.array_equal(f1, f3)


def test_soil_model_rejects_a_model_without_a_bucket():
    from excavsim.errors import ModelError

    m = mujoco.MjModel.from_xml_path(str(constants.SOIL_BOX_XML))
    with pytest.raises(ModelError):
        SoilModel(m, load_scene_config(), get_soil("testbed_sand"), np.random.default_rng(0))


def test_an_unknown_soil_preset_names_the_allowed_ones():
    from excavsim.errors import ConfigError

    scene = load_scene_config().model_copy(update={"soil": "moon_dust"})
    with pytest.raises(ConfigError, match="moon_dust.*allowed: dry_sand, heavy_clay"):
        Simulation(scene=scene)
