"""Sensing: exact ray casting (against mj_multiRay), scanner errors, calibration, median, elevation map."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from excavsim.config import ElevationMapConfig, ScannerConfig, load_sensing_config
from excavsim.errors import ExcavsimError
from excavsim.handoff.maps import ElevationMap, RangeImage
from excavsim.sensing.elevation import build_map, calibrate, map_accuracy, median_ranges, true_cell_heights
from excavsim.world import raycast
from excavsim.world.scanner import LaserScanner
from excavsim.world.settle import settle
from excavsim.world.simulation import Simulation

IDEAL = ScannerConfig(range_noise_m=0.0, scale_drift_per_scan=0.0, offset_drift_m_per_scan=0.0, pose_error_deg=0.0,
                      dropout_probability=0.0, outlier_probability=0.0)


@pytest.fixture(scope="module")
def sim():
    return Simulation(seed=0)


def rough_terrain(sim, rng):
    """A settled random terrain with a trench and a pile, written to the hfield."""
    g = sim.soil.grid
    h = 0.5 + 0.05 * rng.standard_normal(g.shape).cumsum(axis=0).cumsum(axis=1) / 200
    h = np.clip(h, 0.2, 0.9)
    h[40:90, 55:67] -= 0.25
    yy, xx = np.mgrid[:g.shape[0], :g.shape[1]]
    h += np.maximum(0.0, 0.3 - 0.02 * np.hypot(yy - 95, xx - 30))
    h = np.ascontiguousarray(np.clip(h, 0.0, 1.3))
    settle(h, g.cell, math.radians(30), tolerance_m=1e-4)
    return h


def test_cast_matches_mj_multiray_on_rough_terrain(sim, rng):
    """MuJoCo's own ray caster is the reference: same ranges and same geom kind on soil and walls."""
    g = sim.soil.grid
    old = g.heights.copy()
    try:
        g.heights[:] = rough_terrain(sim, rng)
        g.write_hfield(sim.model)
        mujoco.mj_forward(sim.model, sim.data)
        sc = LaserScanner(sim.model, g, IDEAL, np.random.default_rng(0))
        dirs = sc.geometry.directions.reshape(-1, 3)[rng.choice(40_000, 600, replace=False)]
        t, _, kind = sc.true_ranges(dirs)
        # mj_ray from just outside the scanner's own housing, soil (group 0) and box (group 1) only;
        # the floor outside the box is not part of the scanner's scene model
        n = len(dirs)
        geomid = np.zeros(n, np.int32)
        dist = np.zeros(n)
        offset = 0.25
        pnt = sc.geometry.origin + offset * dirs
        for i in range(n):  # one origin per call: rays fan out from the scanner
            gid = np.zeros(1, np.int32)
            dist[i] = mujoco.mj_ray(sim.model, sim.data, pnt[i], dirs[i], np.array([1, 1, 0, 0, 0, 0], np.uint8), 1,
                                    -1, gid)
            geomid[i] = gid[0]
        floor = geomid == sim.model.geom("floor").id
        geomid[floor] = -1
        ref = np.where((dist >= 0) & ~floor, dist + offset, np.inf)
        soil_id = sim.model.geom("soil").id
        ref_kind = np.where(geomid < 0, raycast.HIT_NONE,
                            np.where(geomid == soil_id, raycast.HIT_SOIL, raycast.HIT_BOX))
        np.testing.assert_array_equal(kind, ref_kind)
        hit = np.isfinite(ref)
        assert hit.sum() > 400 and (kind == raycast.HIT_SOIL).sum() > 300
        np.testing.assert_allclose(t[hit], ref[hit], atol=2e-5)  # hfield_data is float32
    finally:
        g.heights[:] = old
        g.write_hfield(sim.model)


def test_scans_reuse_and_recast_only_what_a_change_can_reach_and_equal_a_full_cast(sim, rng):
    """The scanner casts its rays once per terrain and, after a change, recasts only the rays that
    pass low over the changed cells; the ranges equal a from-scratch cast to the bit, for digs, piles
    rising above the old maximum (a new cast bound) and changes no ray can see."""
    g = sim.soil.grid
    saved = g.heights.copy()
    try:
        g.heights[...] = rough_terrain(sim, rng)
        cfg = load_sensing_config().scanner
        scanner = LaserScanner(sim.model, g, cfg, np.random.default_rng(0))
        fresh = LaserScanner(sim.model, g, cfg, np.random.default_rng(0))

        def check(expect_partial: bool) -> None:
            rays_before = scanner.cast_stats["rays"]
            got = scanner.true_ranges()
            want = fresh._cast(fresh._true_dirs, fresh._ztop())
            for a, b in zip(got, want):
                assert np.array_equal(a, b, equal_nan=True)
            cast = scanner.cast_stats["rays"] - rays_before
            if expect_partial:
                assert 0 < cast < 0.2 * len(want[0])

        check(False)
        before = scanner.cast_stats["rays"]
        scanner.true_ranges()  # same terrain: nothing cast
        assert scanner.cast_stats["rays"] == before and scanner.cast_stats["reused"] == 1
        for _ in range(4):  # digs and small piles within the cast bound
            r0, c0 = rng.integers(10, g.shape[0] - 30), rng.integers(10, g.shape[1] - 30)
            g.heights[r0:r0 + 12, c0:c0 + 8] += rng.uniform(-0.08, 0.02, (12, 8))
            check(True)
        g.heights[5, 5] = g.heights.max() + 0.3  # a pile above the bound: a full cast
        full = scanner.cast_stats["full"]
        check(False)
        assert scanner.cast_stats["full"] == full + 1
        # the scans themselves: the same images as a scanner casting every ray afresh
        a = scanner.scan(1.0)
        fresh._cache.clear()
        b = fresh.scan(1.0)
        assert np.array_equal(a.ranges, b.ranges, equal_nan=True)
    finally:
        g.heights[...] = saved


def test_ideal_scanner_reproduces_the_terrain_within_the_cell_discretization(sim, rng):
    g = sim.soil.grid
    old = g.heights.copy()
    try:
        g.heights[:] = rough_terrain(sim, rng)
        sc = LaserScanner(sim.model, g, IDEAL, np.random.default_rng(0))
        emap, _ = build_map([sc.scan(noise=False)], sc.geometry, ElevationMapConfig(calibrate=False))
        truth = true_cell_heights(emap, g.surface_z)
        err = (emap.heights - truth)[emap.observed]
        # a cell's median point against its mean surface: within slope x cell (30 deg x 5 cm), the
        # worst at trench edges where the scanner sees only part of a cell
        assert np.abs(err).max() < math.tan(math.radians(30)) * emap.cell
        assert np.sqrt(np.mean(err ** 2)) < 0.003
        assert emap.observed.mean() > 0.8
    finally:
        g.heights[:] = old


def test_calibration_recovers_an_injected_scale_and_offset(sim):
    cfg = IDEAL.model_copy(update={"range_noise_m": 0.01, "target_rays": 5})
    sc = LaserScanner(sim.model, sim.soil.grid, cfg, np.random.default_rng(3))
    sc.scale_error, sc.offset = 0.03, 0.05  # drift steps are zero: these stay
    image = sc.scan()
    cal = calibrate(image, sc.geometry)
    assert cal.scale == pytest.approx(1.03, abs=0.003)
    assert cal.offset == pytest.approx(0.05, abs=0.012)
    assert cal.rms_residual_m < 0.015  # the 1 cm noise left after correction
    # The corrected image equals the ideal one to the noise level.
    ideal = sc.scan(noise=False).ranges
    ok = np.isfinite(ideal) & np.isfinite(image.ranges)
    resid = cal.correct(image.ranges[ok]) - ideal[ok]
    assert abs(np.mean(resid)) < 0.003 and np.std(resid) < 0.012


def test_calibration_rejects_a_hidden_target(sim):
    sc = LaserScanner(sim.model, sim.soil.grid, IDEAL.model_copy(update={"range_noise_m": 0.005}),
                      np.random.default_rng(4))
    image = sc.scan()
    tr = image.target_ranges.copy()
    tr[2] -= 0.8  # something in front of target 2
    cal = calibrate(RangeImage(image.time, image.ranges, tr), sc.geometry)
    assert cal.scale == pytest.approx(1.0, abs=0.005) and cal.offset == pytest.approx(0.0, abs=0.02)
    assert np.isnan(cal.residuals[2]).all() and cal.n_used == tr.size - tr.shape[1]


def test_median_filter_removes_outliers(sim, rng):
    sc = LaserScanner(sim.model, sim.soil.grid, IDEAL, np.random.default_rng(5))
    clean = sc.scan(noise=False)
    images = []
    for k in range(5):
        r = clean.ranges.copy()
        if k < 2:  # two of five images carry wild ranges on 20 % of their pixels
            wild = (rng.random(r.shape) < 0.2) & np.isfinite(r)
            r[wild] = rng.uniform(0.5, 8.0, int(wild.sum()))
        images.append(RangeImage(0.0, r, clean.target_ranges))
    med = median_ranges(images, None)
    np.testing.assert_array_equal(np.isnan(med), np.isnan(clean.ranges))
    ok = np.isfinite(clean.ranges)
    np.testing.assert_allclose(med[ok], clean.ranges[ok], rtol=0, atol=1e-12)
    cfg = ElevationMapConfig(calibrate=False)
    np.testing.assert_array_equal(build_map(images, sc.geometry, cfg)[0].heights,
                                  build_map([clean], sc.geometry, cfg)[0].heights)


def test_a_pile_and_the_near_wall_leave_hidden_cells_flagged_and_filled_conservatively(sim):
    g = sim.soil.grid
    old = g.heights.copy()
    try:
        yy, xx = np.mgrid[:g.shape[0], :g.shape[1]]
        g.heights[:] = 0.4 + np.maximum(0.0, 0.5 - 0.025 * np.hypot(yy - 60, xx - 60))  # a 0.5 m cone mid-box
        sc = LaserScanner(sim.model, g, IDEAL, np.random.default_rng(0))
        emap, _ = build_map([sc.scan(noise=False)], sc.geometry, ElevationMapConfig(calibrate=False))
        xc, yc = emap.centres()
        # behind the pile as seen from the scanner (y = -2.3, z = 3): the ray over the apex (y = 0,
        # z = 0.9) falls 0.913 m per m and meets the ground at y = 0.55; the 45 deg far flank hides
        behind = emap.observed[np.ix_((yc > 0.15) & (yc < 0.45), (xc > 1.95) & (xc < 2.15))]
        assert not behind.any()
        near_wall = emap.observed[yc < -1.42]  # in the near wall's shadow
        assert near_wall.mean() < 0.2
        in_front = emap.observed[np.ix_((yc > -0.9) & (yc < -0.7), (xc > 1.5) & (xc < 2.6))]
        assert in_front.all()
        # Filled from the highest neighbour: biased high (soil assumed where it was not seen); the
        # last shadow row, filled from the flat ground beyond, can read low.
        truth = true_cell_heights(emap, g.surface_z)
        shadow = ~emap.observed & (yc[:, None] > -0.1) & (yc[:, None] < 0.6) & (abs(xc[None, :] - 2.05) < 0.55)
        err = (emap.heights - truth)[shadow]
        assert shadow.sum() > 40
        assert err.mean() > 0.01 and np.mean(err > -0.01) > 0.65
    finally:
        g.heights[:] = old


def test_default_sensing_is_about_as_accurate_as_the_thesis(sim):
    """§7.1.2: ten calibrated, median-filtered scans leave about 2 cm of error at the targets."""
    cfg = load_sensing_config()
    sc = LaserScanner(sim.model, sim.soil.grid, cfg.scanner, np.random.default_rng(7))
    emap, cals = build_map([sc.scan(0.1 * k) for k in range(cfg.map.n_scans)], sc.geometry, cfg.map)
    acc = map_accuracy(emap, sim.soil.grid.surface_z, cals)
    assert acc.rms_m < 0.025 and acc.max_m < 0.08, acc.summary()
    assert 0.005 < acc.target_rms_m < 0.03, acc.summary()
    assert acc.observed_fraction > 0.85
    assert emap.time == pytest.approx(0.9)


def test_scanner_drift_is_a_slow_random_walk(sim):
    sc = LaserScanner(sim.model, sim.soil.grid, load_sensing_config().scanner, np.random.default_rng(8))
    scales = []
    for _ in range(200):
        sc.drift()
        scales.append(sc.scale_error)
    scales = np.array(scales)
    steps = np.diff(scales)
    assert np.std(steps) == pytest.approx(0.002, rel=0.25)  # the configured step
    assert np.std(scales) > 1.5 * np.std(steps)  # correlated over scans, not white


def test_bad_inputs_are_refused(sim):
    sc = LaserScanner(sim.model, sim.soil.grid, IDEAL, np.random.default_rng(0))
    good = sc.scan(noise=False)
    with pytest.raises(ExcavsimError, match="at least one"):
        build_map([], sc.geometry)
    with pytest.raises(ExcavsimError, match="does not match"):
        build_map([RangeImage(0.0, good.ranges[:10], good.target_ranges)], sc.geometry)
    hidden = RangeImage(0.0, good.ranges, np.full_like(good.target_ranges, np.nan))
    with pytest.raises(ExcavsimError, match="targets hidden"):
        build_map([hidden], sc.geometry)


def test_elevation_map_round_trips_and_interpolates(tmp_path, sim):
    sc = LaserScanner(sim.model, sim.soil.grid, IDEAL, np.random.default_rng(0))
    emap, _ = build_map([sc.scan(noise=False)], sc.geometry)
    path = tmp_path / "map.npz"
    emap.save(path)
    back = ElevationMap.load(path)
    np.testing.assert_array_equal(back.heights, emap.heights)
    np.testing.assert_array_equal(back.observed, emap.observed)
    xc, yc = emap.centres()
    np.testing.assert_allclose(emap.height_at(xc[None, 5:9], yc[10:12, None]), emap.heights[10:12, 5:9])
    (tmp_path / "junk.npz").write_bytes(b"not a map")
    with pytest.raises(ExcavsimError, match="not an elevation map"):
        ElevationMap.load(tmp_path / "junk.npz")


@pytest.mark.parametrize("seed", [2, 4])
def test_levelling_to_the_wall_tops_removes_the_misaligned_mount_s_height_error(sim, seed):
    """A mount misaligned by about 0.4 deg lifts or lowers the whole map by a centimetre or two, which
    the range calibration cannot see; the plane fitted to the points on the walls' tops removes it."""
    cfg = load_sensing_config()
    scanner_cfg = cfg.scanner.model_copy(update={"pose_error_deg": 0.3})
    errors = {}
    for level in (False, True):
        scanner = LaserScanner(sim.model, sim.soil.grid, scanner_cfg, np.random.default_rng((seed, 7)))
        images = [scanner.scan(0.0) for _ in range(cfg.map.n_scans)]
        emap, _ = build_map(images, scanner.geometry, cfg.map.model_copy(update={"level": level}))
        xc, yc = emap.centres()
        xx, yy = np.meshgrid(xc, yc)
        errors[level] = emap.heights - sim.soil.grid.surface_z(xx, yy)
    assert abs(errors[False].mean()) > 0.006
    assert abs(errors[True].mean()) < 0.004
    assert np.sqrt(np.mean(errors[True] ** 2)) < 0.5 * np.sqrt(np.mean(errors[False] ** 2))


def test_levelling_needs_points_on_the_wall_tops(sim):
    from excavsim.sensing.elevation import wall_levelling

    scanner = LaserScanner(sim.model, sim.soil.grid, IDEAL, np.random.default_rng(0))
    inside = np.column_stack([np.random.default_rng(1).uniform(1.0, 3.0, (500, 2)), np.full(500, 0.5)])
    assert wall_levelling(inside, scanner.geometry) is None
    g = scanner.geometry
    x0 = g.area[0] - 0.5 * g.wall_thickness_m
    tops = np.column_stack([np.full(200, x0), np.linspace(-1.4, 1.4, 200), np.full(200, g.wall_top_z + 0.012)])
    level = wall_levelling(np.vstack([inside, tops]), g)
    assert level is not None and level.error_at(x0, 0.0) == pytest.approx(0.012, abs=1e-6)
