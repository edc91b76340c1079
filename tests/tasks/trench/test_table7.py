"""Table 7 (Singh 1995 §7.3) side by side: an episode's per-cycle times, read from the loop's timing
hooks without changing what the episode does."""

from __future__ import annotations

import numpy as np

from excavsim.loop.scenario import EpisodeSpec, run_spec
from excavsim.tasks.trench.timing import THESIS_TABLE7, Table7Timer

TINY = dict(name="tiny", goal="small", dig_budget=1, seed=0,
            sensing={"map": {"n_scans": 2}, "scanner": {"n_azimuth": 60, "n_elevation": 60}},
            planner={"grid": {"k_min_m": 1.8, "k_max_m": 2.6, "k_step_m": 0.2, "alpha_step_deg": 15.0,
                              "d1_step_m": 0.04}})


def test_table7_times_every_phase_of_a_dig_cycle_and_changes_nothing():
    timer = Table7Timer()
    timed = run_spec(EpisodeSpec(**TINY), observer=timer)
    plain = run_spec(EpisodeSpec(**TINY))
    # the same episode with and without the timer
    assert [d.bucket_m3 for d in timed.digs] == [d.bucket_m3 for d in plain.digs]
    assert timed.removed_m3 == plain.removed_m3
    assert len(timer.cycles) == len(timed.digs) == 1
    m = timer.means()
    for key in ("acquisition", "map", "feasible", "select", "park_sim", "home_sim", "execution_sim",
                "setup_wall", "execution_wall"):
        assert np.isfinite(m[key]) and m[key] >= 0, key
    assert m["execution_sim"] > 1.0 and m["park_sim"] + m["home_sim"] > 0.1  # the robot's seconds
    assert m["execution_sim"] == timed.digs[0].sim_s
    table = timer.table()
    for name, sparc, _ in THESIS_TABLE7:
        assert name in table and f"{sparc:.0f}" in table
