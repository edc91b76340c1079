"""The demo job: one scripted dig into the sand, a dump to spoil, and the soil settling."""

from __future__ import annotations

import numpy as np
import pytest

from excavsim.cli import main
from excavsim.errors import ExcavsimError
from excavsim.loop.demo import DEMO_MOVES, Move, format_summary, run_demo
from excavsim.world.simulation import Simulation


@pytest.fixture(scope="module")
def summary():
    return run_demo(Simulation(seed=0))


def test_demo_reaches_every_scripted_pose(summary):
    assert [r.name for r in summary["moves"]] == [m.name for m in DEMO_MOVES]
    for r in summary["moves"]:
        assert r.tip_error_mm < 1.0, r  # the servos settle on the IK target, soil or not
        assert r.pitch_error_deg < 0.1, r


def test_demo_stays_within_the_relief_limits(summary):
    for name, peak in summary["peak_torque_nm"].items():
        assert 0 < peak <= summary["torque_limit_nm"][name] + 1e-6, name


def test_demo_digs_dumps_and_conserves_the_soil(summary):
    """A whole dig, dump and settle: box + bucket + spoil stays at its initial volume."""
    v0, v1 = summary["volumes_initial"], summary["volumes_final"]
    assert v1.total == pytest.approx(v0.total, rel=1e-12, abs=0)
    assert 0.015 < summary["dug_m3"]  # about a bucketful (struck capacity 0.0204 m^3)
    assert summary["dumped_m3"] == pytest.approx(summary["dug_m3"], rel=1e-9)  # all of it left the bucket
    assert v1.bucket == pytest.approx(0.0, abs=1e-12)
    assert summary["settle"].converged
    assert 100 < summary["peak_soil_force_n"] < 3000  # wedge forces of hundreds of N (Fig. 59)


def test_demo_summary_prints_a_table(summary):
    text = format_summary(summary)
    assert "wrist_pitch" in text and "real-time factor" in text and "soil dug" in text


def test_an_unreachable_demo_move_is_refused_before_moving():
    sim = Simulation(seed=0)
    q0 = sim.observe().q
    with pytest.raises(ExcavsimError, match="far away"):
        run_demo(sim, moves=[Move("far away", 0.0, (4.5, 1.0, 0.0))])
    np.testing.assert_array_equal(sim.observe().q, q0)


def test_cli_demo_runs(capsys):
    assert main(["demo", "--seed", "3"]) == 0
    out = capsys.readouterr().out
    assert "swing back" in out and "peak wrist torque" in out
