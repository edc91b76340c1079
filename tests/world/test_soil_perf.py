"""The soil kernel's early-out while the bucket is clear of the terrain changes nothing, to the bit.

:func:`~excavsim.world.kernels.soil_step` skips cutting and bearing while the bucket is above every
terrain sample its loops could read (:func:`~excavsim.world.kernels.clear_of_terrain`); a dig with
its swing to the spoil, dump and return, stepped with the early-out and with it disabled
(``SoilModel.early_out``), must give the same soil contact every step, force and torque and every
other output field, the same terrain and the same bearing pressures, bit for bit.
"""

from __future__ import annotations

import numpy as np
import pytest

from excavsim.config import load_executor_config
from excavsim.world import kernels, soil_records
from excavsim.world.simulation import Simulation
from tests.execution.test_execution import flat_map, planned_dig, run_dig


def _bits(a: np.ndarray) -> np.ndarray:
    """The bytes of a float array, so that equality is to the bit (signed zeros and NaNs included)."""
    return np.ascontiguousarray(a).view(np.uint8)


def _dig(arm, reach_table, *, early_out: bool, seed: int):
    sim = Simulation(seed=seed)
    sim.soil.early_out = early_out
    contacts, pressures, heights = [], [], []

    def keep(s: Simulation) -> None:
        contacts.append(s.contact.record.copy())
        pressures.append(s.soil._pressure.copy())
        if s.steps % 25 == 0:
            heights.append(s.soil.grid.heights.copy())

    sim.step_hooks.append(keep)
    plan = planned_dig(sim, arm, reach_table, flat_map())
    rec = run_dig(sim, arm, load_executor_config(), plan)
    heights.append(sim.soil.grid.heights.copy())
    return sim, rec, np.concatenate(contacts), np.array(pressures), np.array(heights)


@pytest.mark.parametrize("seed", [0, 3])
def test_a_dig_with_its_swings_is_the_same_to_the_bit_with_and_without_the_air_early_out(arm, reach_table, seed):
    fast, rec, c_fast, p_fast, h_fast = _dig(arm, reach_table, early_out=True, seed=seed)
    ref, rec_ref, c_ref, p_ref, h_ref = _dig(arm, reach_table, early_out=False, seed=seed)
    assert ref.soil.clear_steps == 0
    n = len(c_ref)
    assert len(c_fast) == n and fast.steps == ref.steps
    # the dig went into the soil and out to the spoil: the early-out took most of the steps, not all
    assert c_ref["cut_volume_m3"].sum() > 0.01 and c_ref["max_penetration_m"].max() > 0.0
    assert 0.3 * n < fast.soil.clear_steps < n, (fast.soil.clear_steps, n)
    for field in ("force_n", "torque_nm", "cutting_force_n", "bearing_force_n", "load_weight_z_n"):
        assert np.array_equal(_bits(c_fast[field]), _bits(c_ref[field])), field
    assert np.array_equal(_bits(c_fast), _bits(c_ref))  # every output field, the window included
    assert np.array_equal(_bits(p_fast), _bits(p_ref))
    assert np.array_equal(_bits(h_fast), _bits(h_ref))
    assert rec.outcome == rec_ref.outcome
    assert fast.soil.volumes() == ref.soil.volumes()


def _grid(h0: float):
    heights = np.full((40, 40), h0)
    return heights, soil_records.filled(soil_records.GRID, x0_m=0.0, y0_m=0.0, cell_m=0.025, z0_m=0.0)[0]


def test_the_clearance_test_looks_at_every_cell_under_the_bucket_and_fails_safe():
    heights, grid = _grid(0.2)
    box = np.array([[-0.05, -0.05, -0.1], [0.05, 0.05, 0.0]])
    rot = np.eye(3)
    prev = np.array([[0.45, 0.5, 0.31], [0.55, 0.5, 0.31]])
    org = np.array([0.5, 0.5, 0.4])  # lowest sample 0.3 m, 0.1 above the terrain
    assert kernels.clear_of_terrain(heights, grid, org, rot, box, prev)
    heights[20, 20] = 0.31  # one cell right under the bucket rising above its lowest sample
    assert not kernels.clear_of_terrain(heights, grid, org, rot, box, prev)
    heights[20, 20] = 0.2
    heights[20, 25] = 0.31  # beyond the box but within the reach of the depth probes and interpolation
    assert not kernels.clear_of_terrain(heights, grid, org, rot, box, prev)
    heights[20, 25] = 0.2
    heights[20, 32] = 0.5  # far enough away
    assert kernels.clear_of_terrain(heights, grid, org, rot, box, prev)
    low = prev.copy()
    low[0, 2] = 0.19  # the edge's path from the last step went below the surface
    assert not kernels.clear_of_terrain(heights, grid, org, rot, box, low)
    tilted = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # the box's y extent now spans z
    low_org = org - [0, 0, 0.12]  # lowest sample 0.18 m level, 0.23 m tilted
    assert not kernels.clear_of_terrain(heights, grid, low_org, rot, box, prev)
    assert kernels.clear_of_terrain(heights, grid, low_org, tilted, box, prev)
    assert not kernels.clear_of_terrain(heights, grid, low_org - [0, 0, 0.04], tilted, box, prev)
    heights[3, 3] = np.nan
    assert kernels.clear_of_terrain(heights, grid, org, rot, box, prev)  # not under the bucket
    heights[21, 21] = np.nan
    assert not kernels.clear_of_terrain(heights, grid, org, rot, box, prev)
    heights[21, 21] = 0.2
    assert not kernels.clear_of_terrain(heights, grid, org * np.nan, rot, box, prev)
    assert kernels.clear_of_terrain(heights, grid, org + [5.0, 0, 0], rot, box, prev + [5.0, 0, 0])  # off the grid
