"""The objectives (§6.1.3, §6.2.3): utility of feasible digs, eq. 43's cumulative torque and eq. 44's choice."""

from __future__ import annotations

import numpy as np
import pytest

from excavsim.config import load_planner_config
from excavsim.planning.objectives import choose, cumulative_torque

CFG = load_planner_config().model_copy(update={"min_volume_fraction": 0.1})  # eq. 44 at 90 %; below 10 %: no dig
CAPACITY = 0.02  # [m^3]: 90 % is 18 l, 10 % 2 l
FEASIBLE = np.array([True, True, True, True, True, False])
VOLUME = np.array([0.0190, 0.0185, 0.0100, 0.0199, 0.0015, 0.0300])
PEAK = np.array([0.80, 0.60, 0.10, 0.90, 0.01, 0.00])
CUM = np.array([900.0, 800.0, 300.0, 950.0, 10.0, 1.0])


def _choose(objective=None, feasible=FEASIBLE, volume=VOLUME, peak=PEAK, cum=CUM):
    return choose(feasible, volume, peak, cum, CFG, CAPACITY, objective=objective)


def test_eq44_takes_the_smallest_peak_torque_among_digs_reaching_the_volume_threshold():
    c, utility, reason = _choose()
    assert c == 1 and utility == pytest.approx(0.4) and "min peak torque" in reason
    assert CFG.objective == "lexicographic"


def test_eq44_with_the_cumulative_torque_as_auxiliary_criterion():
    """Figs. 113-114: J = 0 up to the threshold z, J2 = 1 / cumulative torque above it (maximized)."""
    cfg = CFG.model_copy(update={"auxiliary": "cumulative_torque"})
    c, utility, reason = choose(FEASIBLE, VOLUME, PEAK, CUM, cfg, CAPACITY)
    assert c == 1 and utility == pytest.approx(1 / 800.0) and "min cumulative torque" in reason
    # J1 must exceed z (eq. 44's ">"): a dig sweeping exactly z x capacity has J = 0
    at_z = VOLUME.copy()
    at_z[1] = 0.9 * CAPACITY
    c, *_ = choose(FEASIBLE, at_z, PEAK, CUM, cfg, CAPACITY)
    assert c == 0


def test_eq44_takes_the_largest_volume_when_no_dig_reaches_the_threshold():
    c, utility, reason = _choose(volume=np.minimum(VOLUME, 0.017))
    assert c in (0, 3) and utility == 0.0 and "max volume" in reason
    c, *_ = _choose(volume=np.array([0.017, 0.0169, 0.01, 0.0, 0.0, 0.03]))
    assert c == 0


def test_each_objective_picks_its_extreme_among_useful_digs():
    assert _choose("volume")[:2] == (3, pytest.approx(0.0199))  # the infeasible 30 l dig does not count
    assert _choose("peak_torque")[:2] == (2, pytest.approx(-0.10))  # the 1.5 l dig is below the minimum
    assert _choose("cumulative_torque")[:2] == (2, pytest.approx(-300.0))


def test_no_dig_when_nothing_is_feasible_or_useful():
    assert _choose(feasible=np.zeros(6, bool)) == (None, 0.0, "no feasible dig")
    c, utility, reason = _choose(feasible=np.array([False, False, False, False, True, False]))
    assert c is None and utility == pytest.approx(0.0015) and "below the minimum" in reason


def test_cumulative_torque_integrates_the_torque_sum_along_the_path():
    """Eq. 43: each sample after the first counts with the length of the segment reaching it."""
    poses = np.array([[2.0, 0.4, 0.0], [1.9, 0.4, 0.0], [1.7, 0.4, 0.0]])
    torques = np.array([[100.0, 0.0, 0.0], [1.0, -2.0, 3.0], [np.nan, 4.0, -6.0]])  # NaN: unknown, counts 0
    assert cumulative_torque(torques, poses) == pytest.approx(6.0 * 0.1 + 10.0 * 0.2)
    both = cumulative_torque(np.stack([torques, 2 * torques]), np.stack([poses, poses]))
    np.testing.assert_allclose(both, [2.6, 5.2])
