"""One cycle of the loop end to end: scan, map, plan on the map, dig, settle, scan again."""

from __future__ import annotations

from excavsim.cli import main
from excavsim.loop.cycle import format_cycle, run_cycle
from excavsim.world.simulation import Simulation


def test_one_cycle_digs_from_the_scanned_map_and_conserves_the_soil():
    sim = Simulation(seed=0)
    s = run_cycle(sim, seed=0)
    assert s["map_before"].rms_m < 0.025 and s["map_before"].observed_fraction > 0.85
    assert s["plan"].action is not None
    assert s["record"].outcome in ("completed", "completed late", "stalled")
    assert s["removed_m3"] > 0.005  # a real dig: litres of soil out of the trench's footprint
    assert abs(s["volumes_final"].total - s["volumes_initial"]) < 1e-12 * s["volumes_initial"]
    assert s["volumes_final"].bucket == 0.0 or s["record"].stall is not None
    assert "soil removed from the trench" in format_cycle(s)


def test_cli_cycle_reports(capsys):
    assert main(["cycle", "--seed", "1"]) == 0
    out = capsys.readouterr().out
    assert "map before" in out and "plan:" in out and "simulated" in out
