"""The reachability lookup table (App. A1-3) against exact IK, and its disk cache."""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np

from excavsim.robot.reachability import ReachabilityTable, TableSpec, load_or_build


def test_table_agrees_with_exact_ik_except_within_one_cell_of_the_boundary(arm, reach_table, rng):
    spec = reach_table.spec
    n = 100_000
    poses = np.stack([rng.uniform(spec.x_min_m, spec.x_max_m, n),
                      rng.uniform(spec.z_min_m, spec.z_max_m, n),
                      np.radians(rng.uniform(spec.pitch_min_deg, spec.pitch_max_deg, n))], axis=-1)
    exact = arm.reachable(poses)
    table = reach_table.contains(poses)
    assert 0.2 < exact.mean() < 0.6
    wrong = exact != table
    assert wrong.mean() < 0.005
    # Every disagreement lies within one cell of the boundary: some pose at most one cell away
    # (1 cm in x or z, 1 degree in pitch) gets the table's answer from exact IK.
    near = np.zeros(wrong.sum(), dtype=bool)
    cell = np.array([spec.dz_m, spec.dz_m, np.radians(spec.dpitch_deg)])  # x judged at the z cell size
    for dx, dz, dp in itertools.product((-1, 0, 1), repeat=3):
        shift = np.array([dx, dz, dp]) * cell
        near |= arm.reachable(poses[wrong] + shift) == table[wrong]
    assert near.all(), poses[wrong][~near][:5]


def test_cells_store_the_extreme_reachable_x(arm, reach_table):
    spec = reach_table.spec
    iz = int(round((0.6 - spec.z_min_m) / spec.dz_m))
    ip = int(round((20.0 - spec.pitch_min_deg) / spec.dpitch_deg))
    z, pitch = spec.z_centres[iz], spec.pitch_centres[ip]
    lo, hi = reach_table.x_min[iz, ip], reach_table.x_max[iz, ip]
    assert np.isfinite(lo) and np.isfinite(hi) and lo < hi
    tol = spec.dx_scan_m / 2 ** spec.refine_iters
    assert arm.reachable(np.array([lo + tol, z, pitch])) and arm.reachable(np.array([hi - tol, z, pitch]))
    assert not arm.reachable(np.array([lo - 2 * tol, z, pitch]))
    assert not arm.reachable(np.array([hi + 2 * tol, z, pitch]))


def test_poses_outside_the_table_extent_are_unreachable(reach_table):
    spec = reach_table.spec
    out = np.array([[1.5, spec.z_max_m + 1.0, 0.0], [1.5, 0.5, np.radians(spec.pitch_max_deg + 10)]])
    assert not reach_table.contains(out).any()


def test_table_is_cached_on_disk_and_reused(arm, tmp_path, monkeypatch):
    spec = TableSpec(z_min_m=0.4, z_max_m=0.6, pitch_min_deg=0.0, pitch_max_deg=10.0)
    first = load_or_build(arm, spec, cache_dir=tmp_path)
    files = list(tmp_path.glob("reach_*.npz"))
    assert len(files) == 1

    def fail(*args, **kwargs):
        raise AssertionError("the cached table should have been loaded, not rebuilt")

    monkeypatch.setattr(ReachabilityTable, "build", classmethod(fail))
    second = load_or_build(arm, spec, cache_dir=tmp_path)
    np.testing.assert_array_equal(first.x_lo, second.x_lo)
    np.testing.assert_array_equal(first.x_hi, second.x_hi)


def test_cache_key_changes_with_the_model_and_the_spec(arm):
    spec = TableSpec()
    other_arm = dataclasses.replace(arm, upper=arm.upper + np.array([0.0, 0.0, 0.01]))
    assert ReachabilityTable.cache_key(arm, spec) != ReachabilityTable.cache_key(other_arm, spec)
    finer = dataclasses.replace(spec, dz_m=0.02)
    assert ReachabilityTable.cache_key(arm, spec) != ReachabilityTable.cache_key(arm, finer)


def test_a_damaged_cache_file_is_rebuilt(arm, tmp_path):
    spec = TableSpec(z_min_m=0.4, z_max_m=0.5, pitch_min_deg=0.0, pitch_max_deg=5.0)
    load_or_build(arm, spec, cache_dir=tmp_path)
    path = next(tmp_path.glob("reach_*.npz"))
    path.write_bytes(b"not an npz file")
    table = load_or_build(arm, spec, cache_dir=tmp_path)
    assert np.isfinite(table.x_min).any()
