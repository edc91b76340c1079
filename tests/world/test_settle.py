"""Soil settlement (Singh 1995 §2.1.2, Fig. 6): volume, repose, symmetry, locality."""

from __future__ import annotations

import math

import numpy as np
import pytest

from excavsim.studies.bench import bench_settle
from excavsim.world.settle import max_slope_excess, settle

CELL = 0.025  # [m], the soil grid of configs/scene.yaml
REPOSE = math.radians(30.0)  # testbed sand, Fig. 6
TOL = 1e-3  # [m]
TAN_L = math.tan(REPOSE) * CELL  # largest stable height step between axis neighbours [m]
TRENCH_ROWS, TRENCH_COLS = (30, 78), (54, 66)  # 1.2 m x 0.3 m


def _trench() -> np.ndarray:
    """121 x 121 cells flat at 0.5 m with a 1.2 x 0.3 x 0.4 m trench with vertical walls."""
    h = np.full((121, 121), 0.5)
    h[slice(*TRENCH_ROWS), slice(*TRENCH_COLS)] -= 0.4
    return h


def _random_terrain(rng: np.random.Generator) -> np.ndarray:
    """Rough terrain far steeper than repose everywhere, touching the walls."""
    return rng.uniform(0.0, 0.5, (60, 80))


def _settled_trench() -> np.ndarray:
    h = _trench()
    assert settle(h, CELL, REPOSE, tolerance_m=TOL).converged
    return h


@pytest.mark.parametrize("terrain", ["random", "trench"])
def test_settlement_conserves_volume(terrain, rng):
    h = _random_terrain(rng) if terrain == "random" else _trench()
    volume = h.sum() * CELL**2
    result = settle(h, CELL, REPOSE, tolerance_m=TOL)
    assert result.moved_volume_m3 > 0.0
    # Walls at the border: nothing leaves the grid, so only round-off may change the volume.
    np.testing.assert_allclose(h.sum() * CELL**2, volume, rtol=1e-12, atol=0)


@pytest.mark.parametrize("terrain", ["random", "trench"])
def test_settled_surface_is_within_tolerance_of_repose(terrain, rng):
    h = _random_terrain(rng) if terrain == "random" else _trench()
    result = settle(h, CELL, REPOSE, tolerance_m=TOL)
    assert result.converged
    assert max_slope_excess(h, CELL, REPOSE) <= TOL
    # The residual settle reports is the reference check over the whole grid, not an estimate.
    assert result.residual_excess_m == max_slope_excess(h, CELL, REPOSE)


@pytest.mark.parametrize("over_relaxation", [1.0, 1.5])
def test_symmetric_trench_settles_symmetrically(over_relaxation):
    """Mirror images of the settled trench agree to well under one repose step.

    Exact symmetry is not to be had: a Gauss-Seidel sweep updates cells in order, so the side swept
    first gives its soil before the other side does, and many stable surfaces exist (any slope up to
    repose + tolerance is accepted), so the two sides can stop at different ones. Alternating the
    sweep direction and sharing each cell's outflow among all its lower neighbours at once keep the
    difference to a few tolerances; the bound is half the height step of one cell on the repose slope.
    """
    h = _trench()
    settle(h, CELL, REPOSE, tolerance_m=TOL, over_relaxation=over_relaxation)
    (r0, r1), (c0, c1) = TRENCH_ROWS, TRENCH_COLS
    window = h[: r0 + r1, : c0 + c1]  # centred on the trench, so mirroring maps the trench onto itself
    assert np.abs(window - window[::-1]).max() < 0.5 * TAN_L
    assert np.abs(window - window[:, ::-1]).max() < 0.5 * TAN_L


def _plane(slope: float, direction_rad: float) -> np.ndarray:
    rows, cols = np.mgrid[0:40, 0:50] * CELL
    return 0.3 + slope * (cols * math.cos(direction_rad) + rows * math.sin(direction_rad))


@pytest.mark.parametrize(
    "terrain",
    [
        np.full((40, 50), 0.3),
        _plane(0.95 * math.tan(REPOSE), math.radians(30.0)),  # below repose in every pair
        _plane(math.tan(REPOSE) + 0.5 * TOL / CELL, 0.0),  # steeper than repose by half the tolerance
    ],
    ids=["flat", "below-repose", "within-tolerance"],
)
def test_stable_terrain_is_left_unchanged(terrain):
    h = terrain.copy()
    result = settle(h, CELL, REPOSE, tolerance_m=TOL)
    np.testing.assert_array_equal(h, terrain)
    assert result.iterations == 0
    assert result.moved_volume_m3 == 0.0
    assert result.converged


def test_vertical_step_relaxes_to_angle_of_repose():
    # Half the grid at 0.6 m, half at 0.2 m, uniform across rows: a 1-D cliff that must become a
    # ramp at exactly tan(repose) (axis pairs bind; diagonals allow sqrt(2) more over sqrt(2) more run).
    h = np.full((8, 120), 0.2)
    h[:, :60] = 0.6
    tol = 1e-4  # a 1 mm tolerance would allow 1 / 14.4 = 7 % steeper slopes on 2.5 cm cells
    assert settle(h, CELL, REPOSE, tolerance_m=tol, max_iterations=10_000).converged
    profile = h.mean(axis=0)
    x = np.arange(profile.size) * CELL
    middle = (profile > 0.3) & (profile < 0.5)  # the middle half of the ramp's 0.4 m drop
    assert middle.sum() >= 10
    slope = -np.polyfit(x[middle], profile[middle], 1)[0]
    np.testing.assert_allclose(slope, math.tan(REPOSE), rtol=0.02)


def test_iteration_cap_reports_an_unconverged_settle():
    h = _trench()
    volume = h.sum()
    result = settle(h, CELL, REPOSE, tolerance_m=TOL, max_iterations=2)
    assert result.iterations == 2
    assert not result.converged
    assert result.residual_excess_m > TOL
    assert result.residual_excess_m == max_slope_excess(h, CELL, REPOSE)
    np.testing.assert_allclose(h.sum(), volume, rtol=1e-12, atol=0)


def _dig(h: np.ndarray, region: tuple[int, int, int, int], depth_m: float) -> None:
    r0, r1, c0, c1 = region
    h[r0:r1, c0:c1] -= depth_m


@pytest.mark.parametrize(
    "region",
    [(90, 102, 20, 32), (50, 62, 40, 52)],  # 0.3 x 0.3 m: on flat ground; cutting into the trench's bank
    ids=["flat-ground", "trench-bank"],
)
def test_region_settle_equals_whole_grid_settle(region):
    # A settled field is stable within the tolerance, so the only moves are those the dig causes:
    # starting from the dug cells must make exactly the moves a whole-grid settle makes.
    dug = _settled_trench()
    _dig(dug, region, 0.1)
    local, whole = dug.copy(), dug.copy()
    result_local = settle(local, CELL, REPOSE, tolerance_m=TOL, region=region)
    result_whole = settle(whole, CELL, REPOSE, tolerance_m=TOL)
    assert result_local.iterations > 0
    np.testing.assert_array_equal(local, whole)
    assert result_local.iterations == result_whole.iterations
    assert result_local.moved_volume_m3 == result_whole.moved_volume_m3
    # The region settle measures its residual only where it went; the whole grid's includes the rest.
    assert result_local.converged and result_whole.converged
    assert result_local.residual_excess_m <= result_whole.residual_excess_m == max_slope_excess(whole, CELL, REPOSE)


def test_region_settle_touches_only_cells_near_the_change():
    before = _settled_trench()
    region = (90, 102, 20, 32)
    _dig(before, region, 0.1)
    after = before.copy()
    settle(after, CELL, REPOSE, tolerance_m=TOL, region=region)
    rows, cols = np.nonzero(after != before)
    # A 0.1 m deep hole fills from banks at most 0.1 m / tan(repose) = 7 cells wide.
    reach = math.ceil(0.1 / TAN_L) + 1
    assert rows.min() >= region[0] - reach and rows.max() < region[1] + reach
    assert cols.min() >= region[2] - reach and cols.max() < region[3] + reach


@pytest.mark.parametrize("repose_deg", [20.0, 45.0, 70.0])
@pytest.mark.parametrize("terrain", ["random", "trench"])
def test_other_angles_of_repose_settle_within_tolerance(repose_deg, terrain, rng):
    h = _random_terrain(rng) if terrain == "random" else _trench()
    volume = h.sum()
    repose = math.radians(repose_deg)
    result = settle(h, CELL, repose, tolerance_m=TOL)
    assert result.converged
    assert max_slope_excess(h, CELL, repose) <= TOL
    np.testing.assert_allclose(h.sum(), volume, rtol=1e-12, atol=0)


def test_steeper_repose_keeps_more_of_the_trench():
    # The settled trench floor rises less when the banks may stand steeper.
    floors = []
    for repose_deg in (20.0, 30.0, 45.0):
        h = _trench()
        settle(h, CELL, math.radians(repose_deg), tolerance_m=TOL)
        floors.append(h[slice(*TRENCH_ROWS), slice(*TRENCH_COLS)].mean())
    assert floors[0] > floors[1] > floors[2]


def test_over_relaxation_does_not_slosh():
    # Over-relaxed moves are capped so that no receiver ends up able to flow back into its donor;
    # without the cap, w near 2 sends soil back and forth (about 3x the volume moved at w = 1).
    moved = {}
    for w in (1.0, 1.99):
        h = _trench()
        result = settle(h, CELL, REPOSE, tolerance_m=TOL, over_relaxation=w)
        assert result.converged
        moved[w] = result.moved_volume_m3
    assert moved[1.99] < 1.25 * moved[1.0]


def test_settle_is_deterministic(rng):
    terrain = _random_terrain(rng)
    first, second = terrain.copy(), terrain.copy()
    assert settle(first, CELL, REPOSE) == settle(second, CELL, REPOSE)
    np.testing.assert_array_equal(first, second)


def test_max_slope_excess_by_hand():
    # One column 0.1 m above a flat 3 x 3 patch: the worst pair is an axis pair,
    # 0.1 - tan(30 deg) * 0.025 = 0.1 - 0.014434 m; diagonals allow sqrt(2) times more.
    h = np.zeros((3, 3))
    h[1, 1] = 0.1
    assert max_slope_excess(h, CELL, REPOSE) == pytest.approx(0.1 - TAN_L, abs=1e-15)
    assert max_slope_excess(np.zeros((3, 3)), CELL, REPOSE) == pytest.approx(-TAN_L, abs=1e-15)
    # A single diagonal pair only (2 x 2, one corner raised by 0.02 m, the others at 0.01 m).
    h = np.array([[0.02, 0.01], [0.01, 0.0]])
    assert max_slope_excess(h, CELL, REPOSE) == pytest.approx(max(0.01 - TAN_L, 0.02 - math.sqrt(2) * TAN_L))


def _fortran(h):
    return np.asfortranarray(h)


@pytest.mark.parametrize(
    ("heights", "kwargs", "match"),
    [
        (np.zeros(10), {}, "2-D"),
        (np.zeros((2, 3, 4)), {}, "2-D"),
        (np.zeros((4, 4), dtype=np.float32), {}, "float64"),
        (_fortran(np.zeros((4, 5))), {}, "C-contiguous"),
        (np.zeros((4, 8))[:, ::2], {}, "C-contiguous"),
        ([[0.0, 1.0], [1.0, 0.0]], {}, "numpy array"),
        (np.array([[0.0, np.nan], [0.0, 0.0]]), {}, "finite"),
        (np.array([[0.0, np.inf], [0.0, 0.0]]), {}, "finite"),
        (np.zeros((4, 4)), {"cell_size_m": 0.0}, "cell_size_m"),
        (np.zeros((4, 4)), {"cell_size_m": -0.1}, "cell_size_m"),
        (np.zeros((4, 4)), {"repose_rad": 0.0}, "repose_rad"),
        (np.zeros((4, 4)), {"repose_rad": math.pi / 2}, "repose_rad"),
        (np.zeros((4, 4)), {"tolerance_m": 0.0}, "tolerance_m"),
        (np.zeros((4, 4)), {"tolerance_m": -1e-3}, "tolerance_m"),
        (np.zeros((4, 4)), {"max_iterations": -1}, "max_iterations"),
        (np.zeros((4, 4)), {"over_relaxation": 2.0}, "over_relaxation"),
        (np.zeros((4, 4)), {"over_relaxation": 0.9}, "over_relaxation"),
        (np.zeros((4, 4)), {"region": (0, 5, 0, 4)}, "does not fit"),
        (np.zeros((4, 4)), {"region": (2, 1, 0, 4)}, "empty"),
        (np.zeros((4, 4)), {"region": (1, 1, 0, 4)}, "empty"),
        (np.zeros((4, 4)), {"region": (-1, 2, 0, 4)}, "does not fit"),
        (np.zeros((4, 4)), {"region": (0, 2, 0)}, "four whole numbers"),
        (np.zeros((4, 4)), {"region": (0.0, 2, 0, 4)}, "four whole numbers"),
    ],
)
def test_invalid_input_raises_value_error(heights, kwargs, match):
    args = {"cell_size_m": CELL, "repose_rad": REPOSE, **kwargs}
    cell, repose = args.pop("cell_size_m"), args.pop("repose_rad")
    with pytest.raises(ValueError, match=match):
        settle(heights, cell, repose, **args)


def test_read_only_heights_are_rejected():
    h = np.zeros((4, 4))
    h.flags.writeable = False
    with pytest.raises(ValueError, match="writeable"):
        settle(h, CELL, REPOSE)


def test_bench_settle_reports_its_rows():
    rows = bench_settle(repeats=1)
    by_label = {label: value for label, value, _, _ in rows}
    assert len(by_label) == len(rows)
    assert all(math.isfinite(v) for v in by_label.values())
    assert by_label["settle trench volume error"] < 1e-12
    assert by_label["settle trench residual excess"] <= TOL * 1e3  # reported in mm
    assert all(isinstance(r, tuple) and len(r) == 4 for r in rows)
