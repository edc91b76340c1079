"""Demonstration and impedance playback (DiMaio 1998 §3.2-3.3, App. A.2, ch. 6)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from excavsim.errors import ExcavsimError
from excavsim.execution.playback import (Admittance, DepthDual, Demonstration, FixedImpedance, ForceVelocityEstimate,
                                         VariableImpedance, critical_damping, dual_stiffness, lambda_from_ratio,
                                         load_demonstration, static_response, weighted_error)

DT = 0.01


def spring_damper_steady(km, ke, be, x0, f0, mm=100.0, steps=4000):
    """The controller's admittance (eq. A.76) against fe = -(Be x' + Ke x), run to steady state."""
    adm = Admittance(np.zeros(1), mm, DT)
    x_prev = x = np.zeros(1)
    for _ in range(steps):
        fe = -(be * (x - x_prev) / DT + ke * x)
        x_prev, x = x, adm.step(np.array([x0]), np.array([f0]), fe, np.array([km]),
                                np.atleast_1d(critical_damping(km, mm)))
    return float(x[0]), float(ke * x[0])


def test_the_impedance_controller_reaches_the_static_duality_response_eqs_3_17_3_18():
    # hand check: Km = 1e4, Ke = 3e4, x0 = 0.1 m, f0 = 2000 N -> x = (2000 + 1000) / 4e4 = 0.075 m, f = 2250 N
    x, f = spring_damper_steady(1e4, 3e4, 500.0, 0.1, 2000.0)
    assert (x, f) == pytest.approx((0.075, 2250.0), rel=1e-6)
    assert static_response(2000.0, 0.1, 1e4, 3e4) == pytest.approx((0.075, 2250.0))


def test_duality_position_source_in_a_soft_environment_force_source_in_a_hard_one():
    # §3.2: against Ke -> 0 a stiff manipulator tracks position; against Ke -> inf a soft one tracks force
    x, _ = spring_damper_steady(1e5, 1.0, 0.0, 0.1, 50.0)
    assert x == pytest.approx(0.1, rel=0.01)
    _, f = spring_damper_steady(10.0, 2e5, 0.0, 0.1, 500.0)
    assert f == pytest.approx(500.0, rel=0.01)


def test_the_dual_stiffness_W_over_Ke_minimises_the_weighted_error_eq_3_21():
    w, ke, x0, f0 = 1e6, 4e4, 0.05, 500.0
    km_star = dual_stiffness(w, ke)
    assert km_star == 25.0
    grid = np.geomspace(1.0, 1e4, 2001)

    def err(km):
        x, f = static_response(f0, x0, km, ke)
        return weighted_error(w, x0 - x, f0 - f)

    e = np.array([err(k) for k in grid])
    assert grid[np.argmin(e)] == pytest.approx(km_star, rel=0.01)
    # the closed form of E: (f0 - Ke x0)^2 (W + Km^2) / (Km + Ke)^2
    assert err(km_star) == pytest.approx((f0 - ke * x0) ** 2 * (w + km_star ** 2) / (km_star + ke) ** 2)
    # when the desired trajectories agree with the environment (f0 = Ke x0) the error is zero for any Km
    assert err(10.0) != 0 and static_response(ke * x0, x0, 10.0, ke)[0] == pytest.approx(x0)


def test_table_6_5_damping_factor_gives_section_6_2_dampings():
    assert critical_damping(1e5, 100.0) == pytest.approx(6324, abs=1)
    assert critical_damping(1e3, 100.0) == pytest.approx(632, abs=1)
    assert critical_damping(1e4, 100.0) == pytest.approx(2000)


def test_the_force_velocity_estimate_converges_on_a_known_damper_environment():
    rng = np.random.default_rng(0)
    be = np.array([3000.0, 12000.0])
    est = ForceVelocityEstimate(2, dt=DT, tau_s=0.2)
    for k in range(500):
        v = np.array([0.15, -0.1]) * (1.0 + 0.3 * np.sin(0.05 * k))
        f = -be * v + rng.normal(0, 5.0, 2)
        z = est.update(f, v)
    assert z == pytest.approx(be, rel=0.02)
    assert est.update(np.array([100.0, 100.0]), np.zeros(2)) == pytest.approx(z)  # at rest: kept


def test_eq_3_37_weight_is_stiff_in_free_motion_soft_against_hard_contact():
    assert lambda_from_ratio(0.0, 150.0, 20.0, 0.3) == 1.0
    assert lambda_from_ratio(1e5, 150.0, 20.0, 0.3) == pytest.approx(0.00075)
    assert lambda_from_ratio(150.0, 150.0, 20.0, 0.3) == 0.5
    assert lambda_from_ratio(5.0, 5.0, 20.0, 0.3) == 0.3  # both below f_min: unchanged
    law = VariableImpedance("v", 100.0, 1e3, 1e5, 1000.0, lambda_tau_s=0.0)
    law.reset(2, DT)
    k, b = law.gains(np.array([0.0, 1e5]), np.array([0.2, 0.01]))
    assert k[0] == pytest.approx(1e5) and k[1] < 1.1e3
    fixed = FixedImpedance("f", 100.0, 1e4)
    fixed.reset(2, DT)
    assert fixed.gains(np.zeros(2), np.zeros(2))[1] == pytest.approx([2000.0, 2000.0])


def demo(n=20):
    t = np.arange(n) * DT
    pose = np.stack([2.0 - 0.1 * t, 0.4 + 0 * t, 0.5 + 0 * t], axis=-1)
    return Demonstration(t, pose, np.zeros((n, 2)) - [100.0, 50.0], DT, 0.0, "test", "testbed_sand")


def test_a_demonstration_round_trips_and_a_bad_file_is_refused(tmp_path):
    d = demo()
    back = load_demonstration(d.save(tmp_path / "d.json"))
    assert np.array_equal(back.pose, d.pose) and np.array_equal(back.force, d.force) and back.soil == d.soil
    doc = json.loads((tmp_path / "d.json").read_text())
    for bad in ({**doc, "version": 2}, {**doc, "force": doc["force"][:-1]}, {k: v for k, v in doc.items() if k != "dt"},
                {**doc, "times": doc["times"][::-1]}, {**doc, "extra": 1}):
        (tmp_path / "bad.json").write_text(json.dumps(bad))
        with pytest.raises(ExcavsimError):
            load_demonstration(tmp_path / "bad.json")
    a = d.with_approach(0.1, 0.5)
    assert len(a.times) == 70 and a.pose[0, 1] == pytest.approx(0.5) and np.all(a.force[:50] == 0)


@pytest.fixture(scope="module")
def recorded():
    from excavsim.apps.playback.driver import record_demonstration
    return record_demonstration(0)


def table_6_5():
    """The T3's impedance (Table 6.5), from its adapter."""
    from excavsim.apps.playback.servo_arm import TABLE_6_5
    return TABLE_6_5


def test_playback_in_the_demonstration_soil_reproduces_it(recorded):
    from excavsim.config import get_soil
    from excavsim.apps.playback.adapter import DEMO_SOIL
    from excavsim.apps.playback.driver import play
    imp = table_6_5()
    d = recorded.with_approach(0.10, 1.0)
    assert len(recorded.times) > 300 and "completed" in recorded.source
    run, _ = play(d, get_soil(DEMO_SOIL), "same", FixedImpedance("position", imp.mass_kg, imp.k_high_n_m))
    e = run.errors(1e6)
    assert run.outcome == "completed"
    assert e["pos_max_m"] < 0.03  # the tip path within 3 cm
    # the force: peak within 10 %, RMS error within 10 % of the demonstrated peak (F/T noise, a new cut)
    assert e["force_peak_n"] == pytest.approx(e["demo_force_peak_n"], rel=0.1)
    assert e["force_rms_n"] < 0.1 * e["demo_force_peak_n"]


def test_the_variable_controller_reproduces_the_demonstration_in_its_own_soil(recorded):
    # Fig. 6.45: eq. 3.37 with the depth law in the unchanged soil. Tolerance (stated): the tip within 2 cm RMS
    # (3.5 cm max) and the force RMS error below 10 % of the demonstrated peak (142 N of 1419 N). With G = 1000
    # it missed by 1.5 cm / 183 N (seed 0; 161-199 N on seeds 0-7: r = |fe| / (G |v|) ~ 9 softened it in its own
    # soil); with the chapter's G = 2000 1.5 cm / 109 N (95-120 N on seeds 0-7; position control 86-112 N).
    from excavsim.config import get_soil
    from excavsim.apps.playback.adapter import DEMO_SOIL, W
    from excavsim.apps.playback.driver import play
    imp = table_6_5()
    d = recorded.with_approach(0.10, 1.0)
    run, _ = play(d, get_soil(DEMO_SOIL), "same", VariableImpedance("variable", imp.mass_kg, imp.k_low_n_m,
                                                                    imp.k_high_n_m, imp.g_n_s_m, depth=DepthDual(w=W)))
    e = run.errors(W)
    assert run.outcome == "completed"
    assert e["pos_rms_m"] < 0.02 and e["pos_max_m"] < 0.035
    assert e["force_rms_n"] < 0.10 * e["demo_force_peak_n"]
    assert e["force_peak_n"] == pytest.approx(e["demo_force_peak_n"], rel=0.1)
    assert np.abs(run.depth).max() < 0.03  # in its own soil the depth law barely moves the path


def test_the_depth_law_sees_no_deficit_when_the_force_is_reproduced_exactly():
    # a rising and falling demonstrated force met exactly (fe = -f0): both magnitudes pass the same filter, so
    # the deficit and the shift stay 0; a filter on |fe| alone would read its own lag as a deficit (here
    # tau * slope = 0.1 s * 2000 N/s = 200 N while rising -> about 2 cm deeper)
    law = DepthDual(w=1e6)
    law.reset(DT)
    t = np.arange(0.0, 2.0, DT)
    mag = 200.0 + 2000.0 * np.minimum(t, 2.0 - t)
    dz = [law.step(np.array([-m, 0.0]), np.array([m, 0.0])) for m in mag]
    assert np.abs(dz).max() < 1e-9
    # a persistent deficit still deepens the cut (the law's purpose)
    law.reset(DT)
    dz = [law.step(np.array([-m, 0.0]), np.array([0.6 * m, 0.0])) for m in mag]
    assert dz[len(t) // 2] > 0.02


def test_the_depth_law_is_the_static_minimiser_of_eq_3_14_in_the_depth():
    # hand check: Ke = 1e4 N/m, W = 1e6, a deficit of 500 N -> dz = 1e4 * 500 / (1e6 + 1e8) = 0.0495 m
    law = DepthDual(ke_n_m=1e4, w=1e6, limit_m=0.3)
    assert law.target(500.0) == pytest.approx(1e4 * 500.0 / 1.01e8)
    grid = np.linspace(-0.3, 0.3, 60001)
    e = 1e6 * grid ** 2 + (500.0 - 1e4 * grid) ** 2
    assert grid[np.argmin(e)] == pytest.approx(law.target(500.0), abs=2e-5)
    assert law.target(-1e6) == -0.3  # clipped
    # with a constant deficit the shift settles on the target through the lag; out of contact it returns to 0
    law.reset(DT)
    for _ in range(400):
        dz = law.step(np.array([-1500.0, 0.0]), np.array([1000.0, 0.0]))
    assert dz == pytest.approx(law.target(500.0), rel=1e-3)
    for _ in range(400):
        dz = law.step(np.zeros(2), np.zeros(2))
    assert abs(dz) < 1e-6


def test_position_control_fails_in_the_changed_soils_and_variable_impedance_beats_both_fixed_ones(recorded):
    from excavsim.apps.playback.adapter import DEMO_SOIL, SOFTER, STIFFER, W, scaled_soil
    from excavsim.apps.playback.driver import play
    imp = table_6_5()
    MASS, K_MIN, K_MAX, G_VARIABLE = imp.mass_kg, imp.k_low_n_m, imp.k_high_n_m, imp.g_n_s_m
    d = recorded.with_approach(0.10, 1.0)
    soils = {"stiffer": scaled_soil(DEMO_SOIL, STIFFER), "softer": scaled_soil(DEMO_SOIL, SOFTER)}
    e = {}
    for name, soil in soils.items():
        for law in (FixedImpedance("position", MASS, K_MAX), FixedImpedance("force", MASS, K_MIN),
                    VariableImpedance("variable", MASS, K_MIN, K_MAX, G_VARIABLE, depth=DepthDual(w=W))):
            run, _ = play(d, soil, name, law)
            assert run.outcome == "completed"
            e[name, law.name] = run.errors(W)
    demo_peak = e["stiffer", "position"]["demo_force_peak_n"]
    # ch. 6's failures of position control: stalled far off the path in the stiffer soil, the force lost in
    # the softer one (the path held)
    assert e["stiffer", "position"]["pos_rms_m"] > 0.1
    assert e["softer", "position"]["pos_rms_m"] < 0.03 and e["softer", "position"]["force_peak_n"] < 0.7 * demo_peak
    # ch. 6's compromise (§6.3, Fig. 6.48): the variable impedance keeps the path better than the low impedance
    # and the force better than position control, and has the least eq. 3.14 error
    for name in soils:
        v, p, f = e[name, "variable"], e[name, "position"], e[name, "force"]
        assert v["weighted_error"] < min(p["weighted_error"], f["weighted_error"]), name
        assert v["force_rms_n"] < p["force_rms_n"] and v["pos_rms_m"] < f["pos_rms_m"], name
    # the stricter reading (issue 24): in the stiffer soil, where the stalled arm also loses the path, both errors
    # are below both fixed extremes' (seeds 0-7: by 7 cm and 190 N at least); in the softer soil the force error
    # is at most a tie with the low impedance's (seeds 0-7: 6-20 N lower on 7, 2 N higher on 1), which buys it with
    # 36 cm of path, while position control, on the path, is closer in position (eqs. 3.8-3.9: both cannot be had)
    v, p, f = e["stiffer", "variable"], e["stiffer", "position"], e["stiffer", "force"]
    assert v["pos_rms_m"] < min(p["pos_rms_m"], f["pos_rms_m"]) and v["force_rms_n"] < min(p["force_rms_n"],
                                                                                            f["force_rms_n"])
    v, f = e["softer", "variable"], e["softer", "force"]
    assert v["force_rms_n"] < f["force_rms_n"] + 0.02 * demo_peak
