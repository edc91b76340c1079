"""Identifying DiMaio's model (DiMaio 1998 §5.5.1, Table 5.3) and calibrating a soil from a record."""

from __future__ import annotations

import math

import numpy as np
import pytest

from excavsim.learning import identify
from excavsim.apps.calibrate import fit as cal
from excavsim.apps.calibrate import table53
from excavsim.world import dimaio, soil_records

TRUE = cal.TABLE_5_3


@pytest.fixture(scope="module")
def generated():
    """Table 5.3's experiment: 1800 samples at 100 Hz of the model with the table's values, no shearing."""
    t = TRUE
    p = soil_records.filled(soil_records.DIMAIO_PARAMS, b_t0=t["b_t0"], b_n0=t["b_n0"], b_a0=0.0, k=t["k"], k_a=0.0,
                            t_rt=t["T_rt"], t_rn=t["T_rn"], t_ra=0.5, shear_s=math.inf, eps=t["eps"], mu=t["mu"],
                            rho_g=t["rho"] * identify.G_M_S2, s_bucket=1.0, width=1.0, v_eps=cal.V_EPS)
    return dimaio.simulate_planar(p, dimaio.trajectory_fig_5_34())


def record(sim, forces):
    return identify.PlanarRecord(sim["r"], sim["z"], sim["t"], sim["n"], sim["sp"], sim["load"], forces, 0.01)


def test_the_identifier_s_own_simulation_is_the_world_s_planar_model(generated):
    """Two implementations of eqs. 5.41-5.49 (the compiled one of the world, numpy in learning) agree."""
    sim = generated
    assert sim["sp"].max() > 0.4 and (sim["sp"] == 0).any() and sim["load"].max() > 0.5  # in, through, out
    np.testing.assert_allclose(identify.simulate(TRUE, record(sim, sim["force_tn"]), v_eps=cal.V_EPS),
                               sim["force_tn"], rtol=1e-9, atol=1e-6)


def test_batch_and_recursive_least_squares_recover_table_5_3_without_noise(generated):
    rec = record(generated, generated["force_tn"])
    ls = identify.batch_least_squares(rec, v_eps=cal.V_EPS)
    hist, _ = identify.recursive_least_squares(rec, forgetting=1.0, v_eps=cal.V_EPS)
    for name in identify.NAMES:
        assert ls[name] == pytest.approx(TRUE[name], rel=1e-6), name
        assert hist[name][-1] == pytest.approx(TRUE[name], rel=1e-6), name


def test_with_the_ft_noise_the_output_error_fit_is_within_its_bound(generated):
    """5 N of F/T noise per axis: the equation-error estimate is biased (the previous force is a noisy
    regressor), the output-error fit of eq. 5.55 from it recovers every parameter within 1 % and
    within five of its standard errors (measured: at most 6e-4 relative)."""
    noisy = generated["force_tn"] + np.random.default_rng(0).normal(0.0, 5.0, generated["force_tn"].shape)
    rec = record(generated, noisy)
    ls = identify.batch_least_squares(rec, v_eps=cal.V_EPS)
    oe, se, rms = identify.output_error_fit(rec, ls, v_eps=cal.V_EPS)
    assert rms == pytest.approx(5.0, rel=0.05)
    for name in identify.NAMES:
        assert oe[name] == pytest.approx(TRUE[name], rel=1e-2), name
        assert abs(oe[name] - TRUE[name]) <= 5 * se[name], name


def test_table_5_3_command_writes_the_table_and_fig_5_40(tmp_path):
    res = table53.table_5_3(tmp_path, noise_n=5.0, say=lambda s: None)
    assert res["batch LS, no noise"]["k"] == pytest.approx(TRUE["k"], rel=1e-6)
    assert (tmp_path / "fig_5_40.png").stat().st_size > 10_000
    assert "T_rn" in (tmp_path / "table_5_3.txt").read_text()


def test_simulate_with_shear_is_the_worlds_planar_model(generated):
    """With a shear strength the identifier's simulation fails the soil as the world's planar step does
    (eq. 5.45: the stiffness relieved where |f_kn| >= S w d_p), sample for sample."""
    t = TRUE
    s_shear = 2.0e4
    p = soil_records.filled(soil_records.DIMAIO_PARAMS, b_t0=t["b_t0"], b_n0=t["b_n0"], b_a0=0.0, k=t["k"], k_a=0.0,
                            t_rt=t["T_rt"], t_rn=t["T_rn"], t_ra=0.5, shear_s=s_shear, eps=t["eps"], mu=t["mu"],
                            rho_g=t["rho"] * identify.G_M_S2, s_bucket=1.0, width=1.0, v_eps=cal.V_EPS)
    sim = dimaio.simulate_planar(p, dimaio.trajectory_fig_5_34())
    assert 5 < sim["sheared"].sum() < len(sim["sheared"]) / 2  # it does shear, now and then
    got = identify.simulate(dict(TRUE, S=s_shear), record(sim, sim["force_tn"]), v_eps=cal.V_EPS, shear=(1.0, 1.0))
    np.testing.assert_allclose(got, sim["force_tn"], rtol=1e-9, atol=1e-6)
    unsheared = identify.simulate(TRUE, record(sim, sim["force_tn"]), v_eps=cal.V_EPS)
    assert np.abs(unsheared - sim["force_tn"]).max() > 100.0  # the shear matters


def test_substeps_reproduce_the_controller_rate_model_from_a_coarser_record():
    """A straight drag at constant depth simulated at 100 Hz, recorded at 10 Hz: the identifier stepped
    10 times per record sample (the path, the axes, the load interpolated) gives the 100 Hz forces."""
    t = TRUE
    p = soil_records.filled(soil_records.DIMAIO_PARAMS, b_t0=t["b_t0"], b_n0=t["b_n0"], b_a0=0.0, k=t["k"], k_a=0.0,
                            t_rt=t["T_rt"], t_rn=t["T_rn"], t_ra=0.5, shear_s=math.inf, eps=t["eps"], mu=t["mu"],
                            rho_g=t["rho"] * identify.G_M_S2, s_bucket=1.0, width=1.0, v_eps=cal.V_EPS)
    n = 301
    a = math.radians(20.0)
    traj = {"r": np.linspace(5.0, 4.4, n), "z": np.full(n, -0.1),
            "t": np.tile([-math.cos(a), -math.sin(a)], (n, 1)), "n": np.tile([-math.sin(a), math.cos(a)], (n, 1)),
            "dt": np.full(n, 0.01)}
    fine = dimaio.simulate_planar(p, traj)
    every = slice(0, n, 10)
    coarse = identify.PlanarRecord(fine["r"][every], fine["z"][every], fine["t"][every], fine["n"][every],
                                   fine["sp"][every], fine["load"][every], fine["force_tn"][every], 0.1)
    got = identify.simulate(TRUE, coarse, v_eps=cal.V_EPS, substeps=10)
    np.testing.assert_allclose(got[1:], fine["force_tn"][every][1:], rtol=1e-6, atol=1e-3)
    assert np.abs(identify.simulate(TRUE, coarse, v_eps=cal.V_EPS)[1:] - fine["force_tn"][every][1:]).max() > 10.0


def test_the_calibrate_command(tmp_path, capsys):
    from excavsim.cli import main

    assert main(["calibrate", "--table-5-3", "--out", str(tmp_path)]) == 0
    assert "output error, 5 N noise" in capsys.readouterr().out
    assert main(["calibrate", "--out", str(tmp_path)]) == 2  # no record
    assert main(["calibrate", str(tmp_path / "rec.rrd"), "--out", str(tmp_path)]) == 2
