"""The testbed's scanner errors (Singh 1995 §7.1.2, Figs. 96-102): each term does what it says, each is
off by default (the default scanner's ranges are today's), each random one has its own stream."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from excavsim import constants
from excavsim.config import ElevationMapConfig, ScannerConfig, load_sensing_config
from excavsim.sensing.elevation import build_map, calibrate_pose, edge_pixels, map_accuracy
from excavsim.world import raycast
from excavsim.world.scanner import LaserScanner, error_stream
from excavsim.world.simulation import Simulation

TESTBED = constants.CONFIGS_DIR / "sensing_testbed.yaml"
# the ideal scanner (no noise, drift, misalignment, dropouts) to which single terms are added
IDEAL = dict(range_noise_m=0.0, scale_drift_per_scan=0.0, offset_drift_m_per_scan=0.0, pose_error_deg=0.0,
             dropout_probability=0.0, outlier_probability=0.0)


@pytest.fixture(scope="module")
def sim():
    return Simulation(seed=3)


def _scanner(sim, seed=3, **terms):
    return LaserScanner(sim.model, sim.soil.grid, ScannerConfig(**{**IDEAL, **terms}), np.random.default_rng((seed, 7)))


def _trench(sim):
    """The box with a 0.3 m deep, steep-walled trench across it (written to the grid only)."""
    g = sim.soil.grid
    h = g.heights.copy()
    h[50:70, 20:100] -= 0.3
    return h


def test_default_scanner_output_is_today_s_for_a_seed(sim):
    """The numbers the scanner gave before the testbed's terms existed (seed 3, ten scans, default
    configs/sensing.yaml): sums and one pixel of the ranges, the target ranges, the map."""
    cfg = load_sensing_config()
    assert not cfg.scanner.testbed_errors
    sc = LaserScanner(sim.model, sim.soil.grid, cfg.scanner, np.random.default_rng((3, 7)))
    ims = [sc.scan(0.1 * k) for k in range(10)]
    r = np.stack([i.ranges for i in ims])
    assert all(i.reflectance is None for i in ims)
    assert float(np.nansum(r)) == pytest.approx(1039362.7291798185, rel=1e-13, abs=0)
    assert float(np.nansum(np.stack([i.target_ranges for i in ims]))) == pytest.approx(2852.828439699165, rel=1e-13)
    assert int(np.isnan(r).sum()) == 87386
    assert float(r[9, 120, 77]) == pytest.approx(3.0624008943371597, rel=1e-14)
    emap, _ = build_map(ims, sc.geometry, cfg.map)
    assert float(emap.heights.sum()) == pytest.approx(1804.432530911628, rel=1e-13)


def test_each_term_has_its_own_stream_and_the_scanner_is_deterministic(sim):
    cfg = load_sensing_config(TESTBED).scanner
    a = LaserScanner(sim.model, sim.soil.grid, cfg, np.random.default_rng((5, 7)))
    b = LaserScanner(sim.model, sim.soil.grid, cfg, np.random.default_rng((5, 7)))
    ia, ib = a.scan(0.0), b.scan(0.0)
    np.testing.assert_array_equal(ia.ranges, ib.ranges)
    np.testing.assert_array_equal(ia.reflectance, ib.reflectance)
    # turning the mount's offset off changes neither the misalignment nor the texture drawn
    c = LaserScanner(sim.model, sim.soil.grid, cfg.model_copy(update={"mount_offset_m": 0.0}),
                     np.random.default_rng((5, 7)))
    np.testing.assert_array_equal(c.misalignment, a.misalignment)
    np.testing.assert_array_equal(c._texture, a._texture)
    assert np.all(c.mount_offset == 0) and np.all(a.mount_offset != 0)
    # the streams are distinct and the episode's generator is not advanced by deriving them
    rng = np.random.default_rng((5, 7))
    s1, s2 = error_stream(rng, 1).random(4), error_stream(rng, 2).random(4)
    assert not np.allclose(s1, s2)
    assert rng.random() == np.random.default_rng((5, 7)).random()


def test_mixed_pixels_appear_only_at_depth_discontinuities(sim):
    g = sim.soil.grid
    old = g.heights.copy()
    try:
        g.heights[:] = _trench(sim)
        line = _scanner(sim).scan(0.0).ranges
        beam = _scanner(sim, beam_divergence_mrad=3.0).scan(0.0).ranges
    finally:
        g.heights[:] = old
    ok = np.isfinite(line) & np.isfinite(beam)
    diff = np.abs(beam - line)
    edges = edge_pixels(line, 0.05)  # jumps of the line beam's image: the trench's lips, the walls' tops
    mixed = ok & (diff > 0.01)
    assert mixed.sum() > 50
    # every pixel the footprint moves by more than a centimetre lies at (or next to) a range jump
    near_edge = edges | np.roll(edges, 1, 0) | np.roll(edges, -1, 0) | np.roll(edges, 1, 1) | np.roll(edges, -1, 1)
    assert np.all(near_edge[mixed])
    # elsewhere the footprint's mean is the centre's range within a millimetre
    assert np.percentile(diff[ok & ~near_edge], 99) < 1e-3
    # and a mixed pixel lies between the foreground and the background
    assert np.median(diff[mixed]) > 0.03


def test_incidence_bias_grows_with_the_angle(sim):
    sc = _scanner(sim, incidence_bias_m=0.004)
    base = _scanner(sim)
    t, cos, kind = base.true_ranges()
    n = base.geometry.directions.shape[0] * base.geometry.directions.shape[1]
    bias = (sc.scan(0.0).ranges.ravel() - base.scan(0.0).ranges.ravel())
    soil = (kind[:n] == raycast.HIT_SOIL) & np.isfinite(bias)
    c = cos[:n][soil]
    np.testing.assert_allclose(bias[soil], 0.004 * (1 / np.maximum(c, math.cos(math.radians(80))) - 1), atol=1e-12)
    steep, shallow = c < 0.6, c > 0.8
    assert steep.any() and shallow.any() and bias[soil][steep].min() > bias[soil][shallow].max()


def test_reflectance_image_and_bias(sim):
    sc = _scanner(sim, reflectance_image=True, reflectance_bias_m=0.006)
    base = _scanner(sim)
    im = sc.scan(0.0)
    assert im.reflectance is not None and im.reflectance.shape == im.ranges.shape
    assert np.all(np.isnan(im.reflectance) == np.isnan(im.ranges))
    # the dark targets read long by k ln(0.3 / 0.1); the soil not at all
    long = im.target_ranges - base.scan(0.0).target_ranges
    assert np.nanmedian(long) == pytest.approx(0.006 * math.log(3.0), abs=1e-9)
    _, cos, kind = base.true_ranges()
    n = im.ranges.size
    soil = kind[:n].reshape(im.ranges.shape) == raycast.HIT_SOIL
    np.testing.assert_allclose(im.ranges[soil], base.scan(0.0).ranges[soil], atol=1e-12)
    # brightness: rho cos (3 m / r)^2, the walls (0.5) brighter than the soil (0.3)
    wall = kind[:n].reshape(im.ranges.shape) == raycast.HIT_BOX
    expect = 0.3 * cos[:n].reshape(im.ranges.shape) * (3.0 / im.ranges) ** 2
    np.testing.assert_allclose(im.reflectance[soil], np.clip(expect[soil], 0, 1), rtol=1e-9)
    assert np.nanmedian(im.reflectance[wall]) > np.nanmedian(im.reflectance[soil])


def _offset_scanner(sim, offset):
    sc = _scanner(sim, mount_offset_m=0.02)
    sc._origin = sc.geometry.origin + np.asarray(offset)  # a known offset for the test
    sc.mount_offset = sc._origin - sc.geometry.origin
    sc._cache.clear()
    return sc


def test_the_target_calibration_finds_the_mount_s_offset(sim):
    """Within 1.5 mm while the target rays stay on their 8 cm plates (the surveyed ranges are to the
    plates' mid-plane, a millimetre behind the faces the rays meet); 2 cm off in x and y, the
    oblique rays at the side walls' targets fall off the plates onto the wall 2 mm behind them and
    bias the fit by a few millimetres."""
    for offset, tol in (([0.008, -0.008, 0.0], 0.0015), ([-0.006, 0.004, 0.0], 0.0015), ([0.02, -0.02, 0.0], 0.005)):
        sc = _offset_scanner(sim, offset)
        pose = calibrate_pose([sc.scan(0.0) for _ in range(3)], sc.geometry)
        np.testing.assert_allclose(pose.position_m[:2], offset[:2], atol=tol)
        assert pose.position_m[2] == 0.0  # z: invisible to targets on vertical walls


def test_the_mount_s_offset_is_removed_from_the_map_by_the_target_calibration(sim):
    """The range calibration alone leaves the map shifted, wall points inside it; with the pose, not."""
    sc = _offset_scanner(sim, [0.02, -0.02, 0.0])
    images = [sc.scan(0.0) for _ in range(3)]
    errs = {}
    for with_pose in (False, True):
        emap, cals = build_map(images, sc.geometry, ElevationMapConfig(level=False, calibrate_pose=with_pose))
        errs[with_pose] = map_accuracy(emap, sim.soil.grid.surface_z, cals).rms_m
    assert errs[True] < 0.3 * errs[False], errs


def test_the_testbed_config_turns_every_term_on():
    cfg = load_sensing_config(TESTBED)
    s = cfg.scanner
    assert s.testbed_errors and s.beam_divergence_mrad > 0 and s.incidence_bias_m > 0 and s.reflectance_bias_m > 0
    assert s.reflectance_image and s.mount_offset_m > 0 and s.soil_reflectance_texture > 0
    assert cfg.map.calibrate_pose and cfg.map.edge_filter_m > 0


def test_the_scanner_and_learning_figures_are_drawn_by_the_figures_command(tmp_path, capsys):
    from excavsim.cli import main
    from excavsim.studies.figures.thesis import figures

    names = figures()
    for n in ("fig68", "fig69", "fig70", "fig71", "fig72", "fig73", "fig74", "fig75", "fig76", "fig77", "fig78",
              "fig79", "fig80", "fig96", "fig97", "fig98", "fig99", "fig102"):
        assert n in names
    assert main(["figures", "fig69", "fig102", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    for n in ("fig69", "fig102"):
        assert (tmp_path / f"{n}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # eq. 18's exact basis fits best, the straight line worst (Fig. 69); the calibration finds a scale
    assert "exact (eq. 18): RMS 0.1" in out
    assert re.search(r"scale (0\.9|1\.0)\d+ \(true", out)


def test_the_testbed_campaign_uses_the_testbed_config_s_scanner():
    """configs/campaigns/sensing_testbed.yaml repeats sensing_testbed.yaml's error terms: they must agree."""
    import yaml

    camp = yaml.safe_load((constants.CONFIGS_DIR / "campaigns" / "sensing_testbed.yaml").read_text())
    testbed, default = load_sensing_config(TESTBED), load_sensing_config()
    changed = {k for k in ScannerConfig.model_fields if getattr(testbed.scanner, k) != getattr(default.scanner, k)}
    assert set(camp["base"]["sensing"]["scanner"]) == changed
    for k, v in camp["base"]["sensing"]["scanner"].items():
        assert getattr(testbed.scanner, k) == v, k
    for k, v in camp["base"]["sensing"]["map"].items():
        assert getattr(testbed.map, k) == v, k
