"""``excavsim figures``: the list, one figure end to end, and the geometry and drives behind them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from excavsim.cli import main
from excavsim.errors import ExcavsimError
from excavsim.studies.figures import drags
from excavsim.studies.figures.thesis import check_names, figures, write_figures
from excavsim.planning.rotation import closest_admissible_radius, drag_rotation_radius, minimum_drag_rake
from excavsim.world.simulation import Simulation

THESIS_FIGURES = ("fig20", "fig22", "fig54", "fig59", "fig61", "fig62", "fig63", "fig82", "fig83", "fig84", "fig85",
                  "fig86", "fig88", "fig91")
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def test_figures_list_names_every_figure_of_the_issue(capsys):
    assert main(["figures", "--list"]) == 0
    out = capsys.readouterr().out
    listed = [line.split()[0] for line in out.splitlines() if line.strip()]
    assert set(THESIS_FIGURES) <= set(listed)
    assert listed == list(figures())  # in the thesis' order


def test_an_unknown_figure_is_refused_with_the_allowed_names(capsys):
    assert main(["figures", "fig9", "--out", "unused"]) == 2
    err = capsys.readouterr().err
    assert "fig9" in err and "fig54" in err and "allowed" in err
    with pytest.raises(ExcavsimError, match="allowed"):
        check_names(["fig54", "nope"])


def test_one_figure_end_to_end_writes_a_png(tmp_path, capsys):
    assert main(["figures", "fig62", "--out", str(tmp_path)]) == 0
    png = tmp_path / "fig62.png"
    assert png.read_bytes()[:8] == PNG_MAGIC and png.stat().st_size > 10_000
    out = capsys.readouterr().out
    assert "N_gamma least" in out and "rho 40.0 deg" in out  # the wedge model's least N_gamma for phi = delta = 30


def test_the_force_trace_figure_drives_the_world_and_reports_its_numbers(tmp_path):
    [(png, summary)] = write_figures(["fig54"], tmp_path)
    assert png.read_bytes()[:8] == PNG_MAGIC
    # eq. 8 at 10 cm, rake 30 deg, 0.3 m wide testbed sand: 102 N, the force just before failure; the
    # bucket's load bears on the wedge as it fills over the 0.6 m (issue 35; measured mean 269 N), so
    # the world's mean lies above eq. 8 and near the planner's prediction, which includes the load
    # (325 N), its failure cycle running between 80 % and 100 % of the failure force
    assert "eq. 8 102 N" in summary
    mean = float(summary.split("mean ")[1].split(" N")[0])
    planner = float(summary.split("planner ")[1].split(" N")[0])
    assert 1.5 * 102 < mean and 0.6 * planner < mean < 1.2 * planner, summary
    assert float(summary.split("largest sample ")[1].split(" N")[0]) < 1.8 * planner, summary


def test_a_drive_records_from_the_start_of_the_returned_motion():
    rec = drags.horizontal_drag(Simulation(seed=0), x0_m=2.3, length_m=0.1, depth_m=0.05, rake_rad=math.radians(30))
    assert rec.s_m[0] == 0.0 and rec.s_m[-1] == pytest.approx(0.1, abs=1e-9)
    np.testing.assert_allclose(rec.depth_m[5:], 0.05, atol=0.005)
    # the tip frame and the plane describe the same force
    np.testing.assert_allclose(np.linalg.norm(rec.force_tip_n, axis=1), rec.magnitude_n, rtol=1e-9, atol=1e-9)
    with pytest.raises(ExcavsimError, match="reach"):
        drags.KinematicDrive(Simulation(seed=0)).place((5.0, 0.5, 0.3))


def test_moving_average_keeps_a_constant_and_smooths_a_step():
    np.testing.assert_allclose(drags.moving_average(np.full(20, 3.0), 9), 3.0)
    step = drags.moving_average(np.r_[np.zeros(10), np.ones(10)], 9)
    assert np.all(np.diff(step) >= 0) and 0 < step[9] < 1


@pytest.mark.parametrize("pitch_deg", [8.0, 15.0, 30.0, 60.0])
def test_the_closest_admissible_centre_is_where_the_bottom_stops_pressing_into_the_soil(pitch_deg):
    """Reuleaux (Figs. 16, 21): rotating clockwise about C = B + (0, h), the far end A of a bottom of
    length L moves away from the soil below it (along -n) above h = L / sin rho and into it below."""
    length, rho = 0.24, math.radians(pitch_deg)
    h_min = float(closest_admissible_radius(length, rho))
    a = length * np.array([math.cos(rho), math.sin(rho)])
    n = np.array([math.sin(rho), -math.cos(rho)])  # the bottom's outer normal, into the soil
    for h, into in ((1.01 * h_min, False), (0.99 * h_min, True)):
        r = a - np.array([0.0, h])
        v = -1.0 * np.array([-r[1], r[0]])  # clockwise unit rotation about C
        assert bool(v @ n > 0) == into


def test_zeta_is_where_the_rotation_centre_meets_the_admissible_one():
    length = 0.24
    for w in (25, 50, 100):
        omega = math.radians(w)
        z = float(minimum_drag_rake(length, omega))
        assert float(closest_admissible_radius(length, z)) == pytest.approx(float(drag_rotation_radius(omega)))
    # the thesis' zeta(50) ~ 8 deg would need a 16 cm bottom; this bucket's 24 cm gives 12.1 deg
    assert math.degrees(float(minimum_drag_rake(length, math.radians(50)))) == pytest.approx(12.1, abs=0.05)
    assert math.isnan(float(minimum_drag_rake(2.0, 1.0)))
    with pytest.raises(ExcavsimError):
        drag_rotation_radius(0.0)


def test_a_drive_is_bit_reproducible_for_a_seed_and_differs_between_seeds():
    def run(seed):
        return drags.horizontal_drag(Simulation(seed=seed), x0_m=2.3, length_m=0.1, depth_m=0.1,
                                     rake_rad=math.radians(30)).force_plane_n

    a = run(4)
    np.testing.assert_array_equal(a, run(4))
    assert not np.array_equal(a, run(5))  # another heterogeneity field
