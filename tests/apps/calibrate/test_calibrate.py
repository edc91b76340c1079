"""Calibrating a soil from a record of digs: recovering a known soil, reading a Rerun recording, the re-run.

The records are made here by the world (quiet: no rate effect, failure-cycle drops or heterogeneity,
so that the soil is the preset's; the inertial term stays, it is mechanics), two digs each, seed 0.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from excavsim.config import get_soil
from excavsim.errors import ExcavsimError
from excavsim.handoff.maps import ElevationMap
from excavsim.learning import identify
from excavsim.learning.wedge_fit import LEAD_M, RecordWedge, advance_speed, load_profile, touchdown_samples
from excavsim.apps.calibrate import fit as cal
from excavsim.apps.calibrate import run as calrun
from excavsim.apps.calibrate import digs as cd
from excavsim.mechanics.wedge import wedge_force
from excavsim.mechanics.wedge_inertia import inertial_force
from excavsim.record import TrenchRecorder
from excavsim.record.reading import read_recording


@pytest.fixture(scope="module")
def sand(tmp_path_factory):
    """Two quiet digs in the testbed sand, as a force record and as a Rerun recording of the episode."""
    d = tmp_path_factory.mktemp("sand")
    data = cd.record_digs(d / "sand.npz", digs=2, seed=0, quiet=True, observer=TrenchRecorder(d / "sand.rrd"))
    return d / "sand.npz", d / "sand.rrd", data


@pytest.fixture(scope="module")
def clay(tmp_path_factory):
    path = tmp_path_factory.mktemp("clay") / "clay.npz"
    return path, cd.record_digs(path, soil="lean_clay", digs=2, seed=0, quiet=True)


def check_recovered(fit, soil, *, c_abs_pa: float, c_rel: float, phi_deg: float | None) -> None:
    """The tolerances stated in the README: gamma within 10 %, delta within 3.5 deg, c within
    max(c_abs_pa, c_rel * c); phi inside the range the record supports (calibrate.phi_interval: 22 of
    24 quiet records, 3 soils x seeds 0-7, 3 digs), and within ``phi_deg`` where the record separates
    c from phi (the clay: 8 of 8 records within 3.5 deg; the sands' records do not, see the README)."""
    params = fit.params
    gamma = soil.density_kg_m3 * identify.G_M_S2
    assert params["gamma_n_m3"] == pytest.approx(gamma, rel=0.10)
    assert abs(params["delta_deg"] - math.degrees(soil.delta)) < 3.5
    assert abs(params["c_pa"] - soil.cohesion_pa) < max(c_abs_pa, c_rel * soil.cohesion_pa)
    lo, hi = fit.phi_range_deg
    assert lo <= math.degrees(soil.phi) <= hi
    if phi_deg is not None:
        assert abs(params["phi_deg"] - math.degrees(soil.phi)) < phi_deg


def test_calibrate_recovers_the_testbed_sand_from_a_record(sand, tmp_path):
    """Measured (2 digs): c 0, phi 31.4, delta 28.4 deg, gamma 19.41 kN/m^3 (true 0, 30, 30, 19.62)."""
    path, _, _ = sand
    fits = calrun.calibrate(path, "wedge", tmp_path, rerun_digs=False, cross_model=False, say=lambda s: None)
    check_recovered(fits["wedge"], get_soil("testbed_sand"), c_abs_pa=1000.0, c_rel=0.0, phi_deg=None)
    assert fits["wedge"].r2 > 0.95
    from excavsim.config import SoilsFile, load_config

    soils = load_config(tmp_path / "sand_wedge.yaml", SoilsFile).soils
    assert next(iter(soils.values())).friction_angle_deg == pytest.approx(fits["wedge"].params["phi_deg"], abs=1e-3)


def test_calibrate_recovers_a_cohesive_soil_from_a_record(clay, tmp_path):
    """Lean clay (c 17.2 kPa, phi = delta 17.2 deg, 17.66 kN/m^3): c within 10 %. Measured (2 digs): c 17.20 kPa,
    phi 18.0, delta 16.9 deg, gamma 18.12 kN/m^3."""
    path, _ = clay
    fits = calrun.calibrate(path, "wedge", tmp_path, rerun_digs=False, cross_model=False, say=lambda s: None)
    check_recovered(fits["wedge"], get_soil("lean_clay"), c_abs_pa=1000.0, c_rel=0.10, phi_deg=3.5)


def _true_theta(soil) -> np.ndarray:
    return np.array([soil.cohesion_pa, soil.phi, soil.delta, soil.density_kg_m3 * identify.G_M_S2])


def test_a_sand_record_does_not_separate_cohesion_from_friction(sand):
    """The limit of the data (§5.2.4.1's "many near-equal minima"): in the sand's record c and phi
    trade along a valley (their estimates' correlation below -0.7; measured -0.78 to -0.92 over 8
    records), the range of phi the record supports (calibrate.phi_interval) is wider than 10 deg
    (measured 13.7 deg on this 2-dig record; median 19.6 deg over 8 quiet records of 3 digs), and
    whatever phi the fit picks, the fitted soil predicts the true soil's forces along the record's
    digs within 7 % (measured 0.9-6.2 % over 20 records): the force is identified, its split into
    c and phi is not."""
    _, _, data = sand
    soil = get_soil("testbed_sand")
    width = float(data.meta["bucket_width_m"])
    fit = cal.fit_wedge(data, soil, width)
    assert fit.correlation[0, 1] < -0.7
    lo, hi = fit.phi_range_deg
    # measured 13.7 deg before the world's load bore on the wedge (issue 35); the load's surcharge,
    # gamma g V^2 / (C D), weighs phi through D apart from eq. 8's d^2 term: 6.3 deg (27.5-33.8) now
    assert hi - lo > 5.0 and lo < 30.0 < hi
    keep = cal._used(data)
    x = RecordWedge.inputs(data.samples, cal._loads(data, width), advance_speed(data["x"], data["t"], data["dig"]))
    rw = RecordWedge(width, load_capacity_m3=cal._heaped_capacity())
    p = fit.params
    fitted = np.array([p["c_pa"], math.radians(p["phi_deg"]), math.radians(p["delta_deg"]), p["gamma_n_m3"]])
    f_fit, f_true = rw.forces(fitted, x[keep]), rw.forces(_true_theta(soil), x[keep])
    assert np.sqrt(((f_fit - f_true) ** 2).sum(1).mean()) < 0.07 * np.sqrt((f_true ** 2).sum(1).mean())
    # the profile is the fit's own cost: at the fitted phi it gives the fit's RMS again
    rms, params = rw.profile(x[keep], data.forces[keep], fitted, np.array([fitted[1]]))
    r = rw.forces(fitted, x[keep]) - data.forces[keep]
    assert rms[0] == pytest.approx(math.sqrt(float((r ** 2).mean())), rel=1e-3)
    np.testing.assert_allclose(params[0, 1], fitted[1])


def test_supported_range_is_where_the_profile_stays_below_the_level():
    """On a parabola ``(v - 20)^2 / 10 + 10`` the level 12.5 is crossed at 15 and 25: found by
    linear interpolation between 2.5-deg grid points; an end where the profile is still below the
    level is the grid's end."""
    v = np.arange(10.0, 45.01, 2.5)
    cost = (v - 20.0) ** 2 / 10.0 + 10.0
    lo, hi = cal.supported_range(v, cost, 12.5)
    assert lo == pytest.approx(15.0) and hi == pytest.approx(25.0)
    assert cal.supported_range(v, cost, 1e9) == (10.0, 45.0)


def test_the_scans_measure_what_each_dig_removed(sand):
    """The record's per-dig removed volume (maps before and after) is the soil that went into the
    bucket: the fit's load; the swept volume alone would be 13-20 % short."""
    _, _, data = sand
    vols = cd.removed_volumes(data)
    assert sorted(vols) == [0, 1]
    for k, vol in vols.items():
        swept = float(data["v"][data["dig"] == k].max())
        assert 1.08 * swept < vol < 1.3 * swept
        assert 0.012 < vol < 0.03  # the T3's bucket holds 20-30 l heaped


def test_removed_volume_counts_the_band_around_the_dig_only():
    """A 10 l hole on the dig's path counts; a heap of spoil 1 m beside the arm plane does not."""
    from excavsim.robot.kinematics import PlanarArm

    class Arm:  # the arm plane along world +x from the origin (waist 0)
        def plane_to_world(self, waist, xz):
            xz = np.asarray(xz, dtype=float)
            return np.stack([xz[:, 0], np.zeros(len(xz)), xz[:, 1]], axis=-1)

    assert PlanarArm  # the real arm has the same plane_to_world signature
    h = np.full((60, 60), 0.5)
    before = ElevationMap(0.0, -1.5, 0.05, h.copy(), np.ones_like(h, bool), 0.0)
    after_h = h.copy()
    after_h[28:32, 36:41] -= 0.1  # 4 x 5 cells of 5 cm, 10 cm deep: 5 l... and the same again:
    after_h[28:32, 41:46] -= 0.1  # 10 l in all, along x 1.8-2.3 m at y -0.1..0.1 m
    after_h[50:54, 36:40] += 0.2  # a heap at y = 1.0 m
    after = ElevationMap(0.0, -1.5, 0.05, after_h, np.ones_like(h, bool), 1.0)
    path = np.array([[2.3, 0.45], [1.8, 0.4]])
    assert cd.removed_volume(before, after, path, Arm(), 0.0, 0.3) == pytest.approx(0.010, rel=1e-9)


def test_record_wedge_is_eq_8_on_flat_ground_and_the_load_weight():
    """On flat ground (l_i all d) the blade force is eq. 8's ``F = (gamma d^2 N_gamma + c d N_c) w`` at
    the probe depth along (-sin delta, -cos delta); the load adds gamma V along (sin rho, -cos rho) and
    its share s as surcharge gamma s V / D."""
    soil = get_soil("sandy_loam")
    theta = np.array([soil.cohesion_pa, soil.phi, soil.delta, soil.density_kg_m3 * identify.G_M_S2])
    rw = RecordWedge(0.3, surcharge_fraction=0.0)
    rake = math.radians(35.0)
    x = np.array([[0.1] * 5 + [rake, 0.0, 0.0]])
    f = rw.forces(theta, x)[0]
    mag = float(wedge_force(0.1, rake, soil.model_copy(update={"adhesion_pa": 0.0}), 0.3))
    np.testing.assert_allclose(f, mag * np.array([-math.sin(soil.delta), -math.cos(soil.delta)]), rtol=1e-9)
    x_load = x.copy()
    x_load[0, 6] = 0.02
    np.testing.assert_allclose(rw.forces(theta, x_load)[0] - f,
                               theta[3] * 0.02 * np.array([math.sin(rake), -math.cos(rake)]), rtol=1e-9)
    out = np.array([[0.0] * 5 + [rake, 0.02, 0.0]])  # out of the soil: the load's weight only
    np.testing.assert_allclose(rw.forces(theta, out)[0], theta[3] * 0.02 * np.array([math.sin(rake),
                                                                                       -math.cos(rake)]))


def test_record_wedge_adds_mckyes_inertia_at_the_advance_speed():
    """With an advance speed ``u`` the blade force grows by McKyes' inertial term ``rho u^2 d N_acc w``
    (rho = gamma / g) along (-sin delta, -cos delta), the force the world adds to its wedge."""
    soil = get_soil("testbed_sand")
    theta = np.array([soil.cohesion_pa, soil.phi, soil.delta, soil.density_kg_m3 * identify.G_M_S2])
    rw = RecordWedge(0.3)
    rake = math.radians(40.0)
    x = np.array([[0.12] * 5 + [rake, 0.01, 0.0]])
    fast = x.copy()
    fast[0, 7] = 0.8
    extra = float(inertial_force(0.12, rake, 0.8, soil, 0.3))
    assert extra > 5.0  # 0.8 m/s: some 10 N
    np.testing.assert_allclose(rw.forces(theta, fast)[0] - rw.forces(theta, x)[0],
                               extra * np.array([-math.sin(soil.delta), -math.cos(soil.delta)]), rtol=1e-9)


def test_advance_speed_is_the_tips_speed_towards_the_base_per_dig():
    t = np.array([0.0, 0.1, 0.2, 0.3, 0.0, 0.1, 0.2])
    x = np.array([2.0, 1.99, 1.98, 1.97, 1.5, 1.52, 1.54])  # dig 0 drags in at 0.1 m/s, dig 1 backs out
    dig = np.array([0, 0, 0, 0, 1, 1, 1])
    np.testing.assert_allclose(advance_speed(x, t, dig), [0.1] * 4 + [0.0] * 3, atol=1e-12)


def test_the_load_leads_the_swept_volume_by_the_soil_just_ahead_of_the_tip():
    """The load is ``v + w LEAD_M l_1`` scaled to the scans' removed volume: at the first sample, the
    tip 4 cm deep, the touch-down has already cut some; at the end (tip out) it is the removed volume."""
    v = np.array([0.0, 0.005, 0.02])
    l1 = np.array([0.04, 0.1, 0.0])
    out = load_profile(v, np.zeros(3), {0: 0.022}, tip_depth_m=l1, width_m=0.3)
    lead = v + 0.3 * LEAD_M * l1
    np.testing.assert_allclose(out, lead * 0.022 / lead.max(), rtol=1e-12)
    assert out[0] > 0 and out[-1] == pytest.approx(0.022)


def test_the_record_model_at_the_true_soil_explains_the_record(sand):
    """At the true soil the record's model, with the world's law of the load bearing on the wedge
    (share V / C of the heaped capacity, issue 35), misses the record by at most 20 N RMS (measured
    14.9 N; noise 5 N, the arm's inertia, the map's depth); without the load surcharge it misses by
    140.6 N, with a constant share s = 0.3 by 91.7 N."""
    _, _, data = sand
    soil = get_soil("testbed_sand")
    theta = np.array([soil.cohesion_pa, soil.phi, soil.delta, soil.density_kg_m3 * identify.G_M_S2])
    keep = cal._used(data)
    width = float(data.meta["bucket_width_m"])
    x = RecordWedge.inputs(data.samples, cal._loads(data, width), advance_speed(data["x"], data["t"], data["dig"]))

    def rms(rw):
        r = rw.forces(theta, x)[keep] - data.forces[keep]
        return math.sqrt(float((r ** 2).mean()))

    cap = cal._heaped_capacity()
    world = rms(RecordWedge(width, load_capacity_m3=cap))
    assert world < 20.0
    assert rms(RecordWedge(width)) > 2 * world  # without the load bearing on the wedge (before issue 35)
    assert rms(RecordWedge(width, surcharge_fraction=0.3)) > 2 * world


def test_touchdown_samples_are_the_rise_off_the_touchdown():
    z = np.array([0.40, 0.41, 0.43, 0.43, 0.40, 0.38, 0.50, 0.49, 0.45])
    dig = np.array([0, 0, 0, 0, 0, 0, 1, 1, 1])
    assert touchdown_samples(z, dig).tolist() == [True, True, False, False, False, False, False, False, False]
    assert load_profile(np.array([0.0, 0.01, 0.02]), np.zeros(3), {0: 0.03}).tolist() == pytest.approx([0, 0.015,
                                                                                                          0.03])


def test_rrd_reading_returns_the_records_samples(sand):
    """The recording's tip-frame F/T samples are the record's, bit for bit; the record built from the
    recording (joint angles through the robot's kinematics, the scanned maps, the logged plans) has
    the same tip poses, depths and swept volumes within millimetres and the same removed volumes."""
    npz, rrd, data = sand
    rec = read_recording(rrd)
    i = np.abs(rec["ft_time"][None, :] - data["t"][:, None]).argmin(axis=1)
    assert np.abs(rec["ft_time"][i] - data["t"]).max() < 1e-6
    np.testing.assert_array_equal(rec["ft_tip"][i, 0], data["fx"])
    np.testing.assert_array_equal(rec["ft_tip"][i, 2], data["fz"])
    assert len(rec["maps"]) == 3 and rec["seed"] == 0 and rec["soil"] == "testbed_sand"
    again = cd.recording_dataset(rec)
    assert again.n_digs == 2 and again.meta["quiet"] == "true" and again.meta["truth"] == "wedge"
    for k in (0, 1):
        a, b = again["dig"] == k, data["dig"] == k
        ta, tb = np.round(again["t"][a], 6), np.round(data["t"][b], 6)
        common = np.intersect1d(ta, tb)
        assert common.size > 0.9 * b.sum()
        ia, ib = np.isin(ta, common), np.isin(tb, common)
        for col, tol in (("fx", 0.0), ("fz", 0.0), ("x", 0.005), ("z", 0.005), ("rake", 0.005), ("l1", 0.005),
                         ("v", 5e-4)):
            assert np.abs(again[col][a][ia] - data[col][b][ib]).max() <= tol, col
    assert cd.removed_volumes(again) == pytest.approx(cd.removed_volumes(data), rel=0.01)
    np.testing.assert_allclose(cd.recorded_actions(again), cd.recorded_actions(data), atol=0.006)


def test_a_recording_without_ft_data_is_refused(tmp_path):
    import rerun as rr

    path = tmp_path / "other.rrd"
    rec = rr.RecordingStream("other", recording_id="x")
    rec.save(str(path))
    rec.set_time("sim_time", duration=0.0)
    rec.log("something", rr.Scalars(1.0))
    rec.flush()
    rec.disconnect()
    with pytest.raises(ExcavsimError, match="no F/T samples in the tip frame"):
        read_recording(path)
    (tmp_path / "junk.rrd").write_text("not a recording")
    with pytest.raises(ExcavsimError, match="not a Rerun recording"):
        read_recording(tmp_path / "junk.rrd")
    with pytest.raises(ExcavsimError, match="no such recording"):
        read_recording(tmp_path / "missing.rrd")


@pytest.mark.slow
def test_calibrate_a_recording_re_runs_the_digs_with_the_fitted_soils(sand, tmp_path, capsys):
    """`excavsim calibrate RECORDING.rrd`: fits both models, re-runs the digs in MuJoCo with each
    fitted soil; the wedge's re-run on its own truth explains the record (measured R^2 0.996), and
    writes the preset and the per-dig plot."""
    from excavsim.cli import main

    _, rrd, _ = sand
    assert main(["calibrate", str(rrd), "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "re-run in MuJoCo" in out and "the scans' removed volume" in out
    line = next(s for s in out.splitlines() if s.strip().startswith("wedge") and "re-run" in s)
    assert float(line.rsplit("R^2", 1)[1]) > 0.95
    assert (tmp_path / "sand_wedge.png").stat().st_size > 20_000
    assert (tmp_path / "sand_wedge.yaml").exists()


def test_calibrate_command_errors_name_the_fix(sand, tmp_path, capsys):
    from excavsim.cli import main

    npz, rrd, _ = sand
    assert main(["calibrate", str(rrd), "--record-digs", "1", "--out", str(tmp_path)]) == 2
    assert "not sand.rrd" in capsys.readouterr().err
    assert main(["calibrate", str(npz), "--rrd", str(tmp_path / "x.rrd"), "--out", str(tmp_path)]) == 2
    assert "give --record-digs too" in capsys.readouterr().err
    assert main(["calibrate", str(tmp_path / "x.rrd"), "--out", str(tmp_path)]) == 2
    assert "no such recording" in capsys.readouterr().err
    assert main(["calibrate", str(tmp_path / "x.txt"), "--record-digs", "1", "--out", str(tmp_path)]) == 2
    assert ".npz, .parquet or .csv" in capsys.readouterr().err
    assert main(["calibrate", str(npz), "--record-digs", "1", "--rrd", "x.txt", "--out", str(tmp_path)]) == 2
    assert "ends in .rrd" in capsys.readouterr().err
    with pytest.raises(ExcavsimError, match="read by the command line"):
        calrun.calibrate(rrd, "wedge", tmp_path)
    with pytest.raises(ExcavsimError, match="allowed: wedge, dimaio"):
        calrun.calibrate(npz, "mohr", tmp_path)


@pytest.fixture(scope="module")
def dimaio_record(tmp_path_factory):
    path = tmp_path_factory.mktemp("dimaio") / "dimaio.npz"
    return cd.record_digs(path, truth="dimaio", digs=2, seed=0)


@pytest.mark.slow
def test_dimaio_fit_on_a_dimaio_record_from_a_start_twice_the_truth(dimaio_record):
    """From every parameter at twice its value, the fitted DiMaio model recovers what dig data
    identify (the README's tolerances, from 12 fits: 4 records of 3 digs, starts twice, half and at
    the truth): the density within 10 % (measured at most 7 %), the Coulomb coefficient within 20 % (16 %),
    the accumulation within 35 % (30 %), the shear strength within 30 % (25 %) and the stiffness
    times the tangential lag, the steady force per drag speed of the lagging centre, within 30 %
    (26 %); stiffness and lags apart, b_t0 (it trades with k T_rt) and b_n0 are not identified.
    And it explains the record better than the fitted wedge. Measured on this record: rho -0.5 %,
    mu +8 %, epsilon -17 %, S -6 %, k T_rt -5 %, R^2 0.96 (the wedge 0.52)."""
    soil = get_soil("testbed_sand")
    true = cal.dimaio_start(soil)
    fit = cal.fit_dimaio(dimaio_record, {k: 2 * v for k, v in true.items()}, s_bucket=0.3, width=0.3)
    p = fit.params
    assert p["rho"] == pytest.approx(true["rho"], rel=0.10)
    assert p["mu"] == pytest.approx(true["mu"], rel=0.20)
    assert p["eps"] == pytest.approx(true["eps"], rel=0.35)
    assert p["S"] == pytest.approx(true["S"], rel=0.30)
    assert p["k"] * p["T_rt"] == pytest.approx(true["k"] * true["T_rt"], rel=0.30)
    assert set(cal.DIMAIO_IDENTIFIED) == {"rho", "mu", "eps", "S", "k*T_rt"}
    wedge = cal.fit_wedge(dimaio_record, soil, 0.3, profile=False)
    assert fit.r2 > 0.8 and fit.r2 > wedge.r2 + 0.2


# -- holding parameters a soil engineer knows (calibrate --fix) --------------------------------------


@pytest.fixture(scope="module")
def sand_seed7(tmp_path_factory):
    """Three quiet digs of the testbed sand, seed 7: a record whose free fit slides down the c-phi
    valley (measured: c 0.26 kPa, phi 22.0 deg)."""
    path = tmp_path_factory.mktemp("sand7") / "sand7.npz"
    return path, cd.record_digs(path, digs=3, seed=7, quiet=True)


def test_holding_cohesion_at_zero_recovers_the_sands_phi(sand_seed7):
    """A sand is cohesionless: c held at 0, phi is fitted within 3 deg (README: 6 of 8 quiet sand
    records, seeds 0-7, within 3 deg, 8 of 8 within 5; free, 3 of 8 within 3 deg); measured on this
    record phi 28.2 deg held against 22.0 free. The held parameter stays exactly at its value, with
    no standard error, and the rest stay within the stated tolerances."""
    _, data = sand_seed7
    soil = get_soil("testbed_sand")
    width = calrun._bucket_width()
    held = cal.fit_wedge(data, soil, width, fixed={"c_pa": 0.0})
    assert held.params["c_pa"] == 0.0 and held.errors["c_pa"] == 0.0 and held.fixed == {"c_pa": 0.0}
    assert abs(held.params["phi_deg"] - 30.0) < 3.0
    assert abs(held.params["delta_deg"] - 30.0) < 3.5
    assert held.params["gamma_n_m3"] == pytest.approx(soil.density_kg_m3 * identify.G_M_S2, rel=0.10)
    lo, hi = held.phi_range_deg
    assert lo <= 30.0 <= hi
    free = cal.fit_wedge(data, soil, width, profile=False)
    # the hold is knowledge, not a better fit: the free fit explains the record at least as well
    assert free.rms_n <= held.rms_n + 1e-6
    # a held phi is not profiled, and two held parameters stay put
    both = cal.fit_wedge(data, soil, width, fixed={"c_pa": 0.0, "phi_deg": 30.0})
    assert both.phi_range_deg is None
    assert both.params["phi_deg"] == pytest.approx(30.0, abs=1e-9) and both.errors["phi_deg"] == 0.0


def test_parse_fixes_takes_the_printed_and_the_presets_names():
    assert cal.parse_fixes("wedge", ["cohesion_pa=0", "delta_deg=28.5"]) == {"c_pa": 0.0, "delta_deg": 28.5}
    assert cal.parse_fixes("dimaio", ["rho=1700", "T_rt=0.1"]) == {"rho": 1700.0, "T_rt": 0.1}
    assert cal.parse_fixes("wedge", None) == {}
    for bad, msg in (["phi_deg"], "give NAME=VALUE"), (["c_pa=0", "cohesion_pa=1"], "held twice"), \
            (["c_pa=0", "phi_deg=30", "delta_deg=30", "gamma_n_m3=19000"], "nothing is left to fit"), \
            (["phi_deg=nan"], r"phi_deg must be a number in \[10, 45\]"):
        with pytest.raises(ExcavsimError, match=msg):
            cal.parse_fixes("wedge", bad)


@pytest.mark.slow
def test_calibrate_fix_on_the_command_line(sand, tmp_path, capsys):
    """``--fix`` holds the parameter in the printed fit; a bad NAME or VALUE exits 2 naming the
    allowed names and ranges, before any recording or fit."""
    from excavsim.cli import main

    npz, _, _ = sand
    assert main(["calibrate", str(npz), "--fix", "cohesion_pa=0", "--no-rerun", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert next(s for s in out.splitlines() if s.strip().startswith("c_pa")).split()[1:] == ["0", "(held)"]
    assert "c_pa 0 held" in out
    cases = ((["--fix", "cohesion=0"], "'cohesion' is not a parameter of the wedge fit; allowed: c_pa in [0, 100000], "
              "phi_deg in [10, 45], delta_deg in [5, 45], gamma_n_m3 in [5000, 40000]"),
             (["--fix", "phi_deg=60"], "phi_deg must be a number in [10, 45]"),
             (["--fix", "phi_deg=thirty"], "phi_deg must be a number in [10, 45]"),
             (["--model", "dimaio", "--fix", "c_pa=0"], "'c_pa' is not a parameter of the dimaio fit; allowed: b_t0"),
             (["--model", "dimaio", "--fix", "T_rt=0"], "T_rt must be a number in [0.001, 1000]"),
             (["--record-digs", "1", "--fix", "x=1"], "'x' is not a parameter"))
    for extra, msg in cases:
        assert main(["calibrate", str(tmp_path / "new.npz" if "--record-digs" in extra else npz), *extra,
                     "--out", str(tmp_path)]) == 2
        assert msg in capsys.readouterr().err
    assert not (tmp_path / "new.npz").exists()
    assert main(["calibrate", "--table-5-3", "--fix", "rho=1", "--out", str(tmp_path)]) == 2
    assert "--table-5-3 identifies" in capsys.readouterr().err


@pytest.mark.parametrize("header_keeps_forces", [False, True])
def test_calibrate_on_a_csv_without_the_force_columns_names_the_file_and_the_columns(tmp_path, capsys,
                                                                                     header_keeps_forces):
    """A CSV force record whose rows lack fx and fz (with or without them in the header) is refused
    with exit 2 and a message naming the file and what is missing; it ended in an IndexError (exit 1)."""
    from excavsim.cli import main
    from excavsim.learning.dataset import COLUMNS, ForceDataset

    full = tmp_path / "full.csv"
    ForceDataset({c: np.arange(12.0) for c in COLUMNS}, {"soil": "testbed_sand"}).save(full)
    meta, header, *rows = full.read_text().splitlines()
    keep = [i for i, c in enumerate(COLUMNS) if c not in ("fx", "fz")]
    cut = tmp_path / "no_forces.csv"
    cut.write_text("\n".join([meta, header if header_keeps_forces else ",".join(COLUMNS[i] for i in keep),
                              *(",".join(r.split(",")[i] for i in keep) for r in rows)]) + "\n")
    assert main(["calibrate", str(cut), "--out", str(tmp_path / "out"), "--no-rerun"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("excavsim: error: ") and str(cut) in err and "Traceback" not in err
    assert ("line 3 has 26 values under a header of 28 columns" in err if header_keeps_forces
            else "missing the column(s) fx, fz" in err)
