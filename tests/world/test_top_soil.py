"""The testbed's second soil (Singh 1995 §7.2.2): a preset whose numbers are assumed but whose forces,
as the thesis found, sit close to the testbed sand's."""

from __future__ import annotations

import math

import pytest

from excavsim.config import get_soil
from excavsim.mechanics.wedge import wedge_force


def test_top_soil_preset_is_stated_and_close_to_the_sand_where_the_digs_are():
    top, sand = get_soil("top_soil"), get_soil("testbed_sand")
    assert "assumed" in top.description and "§7.2.2" in top.description
    assert top.cohesion_pa > 0 and top.density_kg_m3 < sand.density_kg_m3
    assert top.repose_angle_deg > sand.repose_angle_deg  # moist: stands steeper until it dries
    for depth in (0.10, 0.15, 0.20):  # the thesis' learning could not tell the two soils' forces apart
        f_top = float(wedge_force(depth, math.radians(30), top, 0.4))
        f_sand = float(wedge_force(depth, math.radians(30), sand, 0.4))
        assert f_top == pytest.approx(f_sand, rel=0.25)
    # shallow, the cohesion shows
    assert float(wedge_force(0.05, math.radians(30), top, 0.4)) > 1.3 * float(
        wedge_force(0.05, math.radians(30), sand, 0.4))
