"""The wedge model (Singh 1995 §5.1.2.1, eqs. 3-11) against hand derivations and its own equations.

The reference values below use the thesis' formulas literally (cotangents, plain ``math``), not the
closed forms of the module, and a scalar bisection on the slope of eq. 9 for the critical angle.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from excavsim.config import get_soil
from excavsim.mechanics.wedge import (G_M_S2, WedgeError, WedgeTable, blade_axes, critical_beta, force_angle,
                                      n_factors, surcharge_force, tip_to_plane, wedge_denominator, wedge_factors,
                                      wedge_force, wedge_force_components)

SOILS = ("testbed_sand", "sandy_loam", "dry_sand", "heavy_clay", "lean_clay")
DEG = math.pi / 180.0


def cot(x: float) -> float:
    return math.cos(x) / math.sin(x)


def thesis_denominator(rho: float, beta: float, phi: float, delta: float) -> float:
    return math.cos(rho + delta) + math.sin(rho + delta) * cot(beta + phi)  # eqs. 9-11


def thesis_n(rho: float, beta: float, phi: float, delta: float) -> tuple[float, float, float, float]:
    """Eqs. 9, 10, 11 and eq. 5's adhesion factor, written as in the thesis."""
    den = thesis_denominator(rho, beta, phi, delta)
    n_gamma = (cot(rho) + cot(beta)) / (2.0 * den)
    n_c = (1.0 + cot(beta) * cot(beta + phi)) / den
    n_q = (cot(rho) + cot(beta)) / den
    n_a = (1.0 - cot(rho) * cot(beta + phi)) / den
    return n_gamma, n_c, n_q, n_a


def thesis_beta(rho: float, phi: float, delta: float) -> float:
    """beta in (0, pi/2] minimizing eq. 9, by bisection on the sign of dN_gamma/dbeta (plain math).

    With ``D`` the denominator, ``dD/dbeta = -sin(rho + delta) csc^2(beta + phi)`` and
    ``2 D^2 dN_gamma/dbeta = -csc^2(beta) D + (cot rho + cot beta) sin(rho + delta) csc^2(beta + phi)``:
    negative as beta -> 0, positive as D -> 0. If it is still negative at pi/2 the minimum is there.
    """

    def slope(b: float) -> float:
        den = thesis_denominator(rho, b, phi, delta)
        return -den / math.sin(b) ** 2 + (cot(rho) + cot(b)) * math.sin(rho + delta) / math.sin(b + phi) ** 2

    lo, hi = 1e-9, min(0.5 * math.pi, math.pi - rho - phi - delta - 1e-12)
    if slope(hi) < 0:
        return hi
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if slope(mid) < 0 else (lo, mid)
    return 0.5 * (lo + hi)


@pytest.fixture(scope="module")
def sand():
    return get_soil("testbed_sand")


@pytest.fixture(scope="module")
def sand_table(sand):
    return WedgeTable.for_soil(sand)


def test_testbed_sand_at_30deg_rake_matches_hand_derivation(sand, sand_table):
    rho = phi = delta = 30 * DEG
    assert sand.phi == pytest.approx(phi) and sand.delta == pytest.approx(delta)
    # Hand derivation at rho = phi = delta = 30 deg, beta = 30 deg:
    #   cot rho + cot beta = 2 sqrt3;  cot(beta + phi) = cot 60 = 1/sqrt3;
    #   D = cos 60 + sin 60 / sqrt3 = 1/2 + 1/2 = 1
    #   N_gamma = 2 sqrt3 / 2 = sqrt3;  N_c = 1 + sqrt3 / sqrt3 = 2;  N_q = 2 sqrt3;  N_a = 1 - 1 = 0.
    # beta = 30 deg is stationary: dN_gamma/dbeta = [-csc^2(beta) D + (cot rho + cot beta) sin(rho + delta)
    #   csc^2(beta + phi)] / (2 D^2) = [-4 + 2 sqrt3 (sqrt3/2)(4/3)] / 2 = (-4 + 4) / 2 = 0,
    # and a bisection on the sign of that slope (thesis_beta) confirms it is the minimum.
    assert thesis_beta(rho, phi, delta) == pytest.approx(30 * DEG, abs=1e-12)
    beta = critical_beta(rho, sand.phi, sand.delta)
    assert beta == pytest.approx(30 * DEG, abs=1e-9)
    np.testing.assert_allclose(n_factors(rho, beta, sand.phi, sand.delta), [math.sqrt(3), 2.0, 2 * math.sqrt(3), 0.0],
                               rtol=1e-12, atol=1e-12)
    assert wedge_denominator(rho, beta, sand.phi, sand.delta) == pytest.approx(1.0, rel=1e-12)
    expected = 2000.0 * 9.81 * 0.1**2 * math.sqrt(3) * 0.3  # gamma g d^2 N_gamma w, eq. 8 with c = q = 0
    assert wedge_force(0.1, rho, sand, 0.3) == pytest.approx(expected, rel=1e-12)
    assert wedge_force(0.1, rho, sand, 0.3, table=sand_table) == pytest.approx(expected, rel=1e-6)


def test_cohesion_term_is_c_d_n_c_w_for_sandy_loam():
    loam = get_soil("sandy_loam")
    rho, d, w = 45 * DEG, 0.12, 0.3
    beta = thesis_beta(rho, loam.phi, loam.delta)
    n_gamma, n_c, _, _ = thesis_n(rho, beta, loam.phi, loam.delta)
    expected = (loam.density_kg_m3 * 9.81 * d**2 * n_gamma + loam.cohesion_pa * d * n_c) * w  # eq. 8, q = 0
    assert critical_beta(rho, loam.phi, loam.delta) == pytest.approx(beta, abs=1e-12)
    assert wedge_force(d, rho, loam, w) == pytest.approx(expected, rel=1e-9)
    cohesionless = loam.model_copy(update={"cohesion_pa": 0.0})
    cohesion_part = wedge_force(d, rho, loam, w) - wedge_force(d, rho, cohesionless, w)
    assert cohesion_part == pytest.approx(loam.cohesion_pa * d * n_c * w, rel=1e-9)


def test_surcharge_term_is_q_d_n_q_w_and_equals_the_surcharge_weight_over_d(sand, sand_table):
    rho, d, w, q = 30 * DEG, 0.1, 0.3, 500.0
    # From the 30 deg derivation above: N_q = 2 sqrt3, D = 1, cot rho + cot beta* = 2 sqrt3.
    term = q * d * 2 * math.sqrt(3) * w
    with_q = wedge_force(d, rho, sand, w, surcharge_pa=q)
    assert with_q - wedge_force(d, rho, sand, w) == pytest.approx(term, rel=1e-9)
    # The same load as soil resting on the wedge: Q w = q d (cot rho + cot beta) w (eq. 7) of weight.
    volume = q * d * 2 * math.sqrt(3) * w / (sand.density_kg_m3 * G_M_S2)
    assert surcharge_force(volume, rho, sand) == pytest.approx(term, rel=1e-9)
    assert surcharge_force(volume, rho, sand, table=sand_table) == pytest.approx(term, rel=1e-6)
    assert wedge_force(d, rho, sand, w, surcharge_volume_m3=volume) == pytest.approx(with_q, rel=1e-9)
    assert surcharge_force(0.0, rho, sand) == 0.0


def test_cohesionless_force_grows_exactly_as_depth_squared(sand, rng):
    d = rng.uniform(0.01, 0.3, 200)
    rake = rng.uniform(5 * DEG, 110 * DEG, 200)
    np.testing.assert_array_equal(wedge_force(2 * d, rake, sand, 0.3), 4 * wedge_force(d, rake, sand, 0.3))


def test_cohesion_term_grows_linearly_with_depth(rng):
    loam = get_soil("sandy_loam")
    cohesionless = loam.model_copy(update={"cohesion_pa": 0.0})
    d = rng.uniform(0.01, 0.3, 200)
    rake = rng.uniform(5 * DEG, 110 * DEG, 200)

    def cohesion_part(depth):
        return wedge_force(depth, rake, loam, 0.3) - wedge_force(depth, rake, cohesionless, 0.3)

    np.testing.assert_allclose(cohesion_part(2 * d) / cohesion_part(d), 2.0, rtol=1e-9)


@pytest.mark.parametrize("rake_deg", [10.0, 30.0, 60.0, 85.0])
def test_n_gamma_has_an_interior_minimum_in_beta(sand, rake_deg):
    rho = rake_deg * DEG
    beta = float(critical_beta(rho, sand.phi, sand.delta))
    assert 1 * DEG < beta < 89 * DEG

    def n_gamma(b):
        return n_factors(rho, b, sand.phi, sand.delta)[0]

    h = 1e-5
    slope = (n_gamma(beta + h) - n_gamma(beta - h)) / (2 * h)
    assert abs(slope) < 1e-6 * n_gamma(beta)
    for other in (beta - 5 * DEG, beta + 5 * DEG, 1 * DEG, 89 * DEG):
        assert n_gamma(other) > n_gamma(beta)


@pytest.mark.parametrize("phi_deg, delta_deg",
                         [(30, 30), (29, 29), (17.2, 17.2), (34, 34), (30, 10), (10, 0), (45, 20)])
def test_critical_beta_matches_scipy_bounded_minimization(phi_deg, delta_deg):
    phi, delta = phi_deg * DEG, delta_deg * DEG
    limit = 180 - phi_deg - delta_deg
    rakes = np.radians(np.arange(2.0, limit - 1.0, 3.0))
    betas = critical_beta(rakes, phi, delta)
    for rho, beta in zip(rakes, betas, strict=True):
        hi = min(0.5 * math.pi, math.pi - rho - phi - delta)

        def f(b, rho=rho):
            den = thesis_denominator(rho, b, phi, delta)
            return math.inf if den <= 0 else (cot(rho) + cot(b)) / (2.0 * den)

        ref = minimize_scalar(f, bounds=(1e-9, hi - 1e-12), method="bounded", options={"xatol": 1e-12})
        assert beta == pytest.approx(ref.x, abs=1e-6), f"rake {math.degrees(rho):.1f} deg"
        assert n_factors(rho, beta, phi, delta)[0] <= ref.fun * (1 + 1e-12)


def test_critical_beta_of_a_vertical_frictionless_wall_is_the_rankine_passive_angle():
    # delta = 0, rho = 90 deg: Coulomb's passive wedge fails at 45 deg - phi / 2 from horizontal.
    phi = np.radians([10.0, 20.0, 30.0, 40.0])
    np.testing.assert_allclose(critical_beta(0.5 * math.pi, phi, 0.0), 0.25 * math.pi - phi / 2, atol=1e-12)


def test_n_factors_equal_the_thesis_formulas_and_n_q_is_twice_n_gamma(rng):
    for _ in range(300):
        phi, delta = rng.uniform(5, 45) * DEG, rng.uniform(0, 45) * DEG
        rho = rng.uniform(1, 179 - math.degrees(phi + delta)) * DEG
        beta = rng.uniform(0.5, min(89.5, 179.5 - math.degrees(rho + phi + delta))) * DEG
        np.testing.assert_allclose(n_factors(rho, beta, phi, delta), thesis_n(rho, beta, phi, delta),
                                   rtol=1e-9, atol=1e-12)
        assert wedge_denominator(rho, beta, phi, delta) == pytest.approx(thesis_denominator(rho, beta, phi, delta),
                                                                         rel=1e-9, abs=1e-12)
    rho = np.radians(np.linspace(1, 119, 50))
    beta = critical_beta(rho, 30 * DEG, 30 * DEG)
    n_gamma, _, n_q, _ = n_factors(rho, beta, 30 * DEG, 30 * DEG)
    np.testing.assert_array_equal(n_q, 2 * n_gamma)  # eq. 11 is eq. 9 without the 1/2


def test_impossible_geometry_gives_infinite_factors_and_force(sand):
    phi = delta = 30 * DEG
    # rho + beta + phi + delta >= pi: D <= 0.
    assert np.all(np.isinf(n_factors(100 * DEG, 60 * DEG, phi, delta)))
    assert wedge_denominator(100 * DEG, 60 * DEG, phi, delta) <= 0
    assert np.isnan(critical_beta(125 * DEG, phi, delta))
    assert np.isinf(wedge_force(0.1, 125 * DEG, sand, 0.3))
    assert wedge_force(np.array([0.0, -0.05]), 125 * DEG, sand, 0.3).tolist() == [0.0, 0.0]


def test_force_falls_then_rises_with_rake_in_testbed_sand(sand):
    # Figs. 61-62: the force first drops as the rake grows, then increases.
    rake_deg = np.arange(10.0, 81.0, 1.0)
    force = wedge_force(0.1, np.radians(rake_deg), sand, 0.3)
    k = int(np.argmin(force))
    assert 0 < k < len(force) - 1
    assert np.all(np.diff(force[: k + 1]) < 0) and np.all(np.diff(force[k:]) > 0)
    assert rake_deg[k] == 40.0  # the magnitude's minimum; the horizontal draft's is nearer 30 deg
    at_experiments = wedge_force(0.1, np.radians([20.0, 30.0, 40.0, 50.0]), sand, 0.3)
    assert at_experiments[0] > at_experiments[1] > at_experiments[2] < at_experiments[3]


def test_critical_beta_rises_then_falls_with_rake_in_testbed_sand(sand):
    # Fig. 62: beta* is non-monotonic in the rake. For the testbed sand it rises from ~7.5 deg at a
    # 1 deg rake to a peak of 30 deg at a 30 deg rake, then falls towards 0 as rho -> pi - phi - delta.
    rake_deg = np.arange(1.0, 119.95, 0.1)
    beta = np.degrees(critical_beta(np.radians(rake_deg), sand.phi, sand.delta))
    k = int(np.argmax(beta))
    assert rake_deg[k] == pytest.approx(30.0, abs=0.06) and beta[k] == pytest.approx(30.0, abs=1e-6)
    assert np.all(np.diff(beta[: k + 1]) > 0) and np.all(np.diff(beta[k:]) < 0)
    assert beta[-1] < 0.1


def test_testbed_sand_forces_at_5_10_15_cm_are_tens_to_hundreds_of_newtons(sand):
    force = wedge_force(np.array([0.05, 0.10, 0.15]), 30 * DEG, sand, 0.3)
    # gamma g d^2 sqrt3 w: 25.5, 102, 229 N.
    np.testing.assert_allclose(force, 2000 * 9.81 * np.array([0.05, 0.10, 0.15]) ** 2 * math.sqrt(3) * 0.3, rtol=1e-12)
    assert np.all(np.diff(force) > 0) and 10.0 < force[0] and force[-1] < 1000.0


@pytest.mark.parametrize("name", SOILS)
def test_table_lookup_agrees_with_exact_factors_over_the_valid_range(name):
    soil = get_soil(name)
    table = WedgeTable.for_soil(soil)
    assert table.rake_min == pytest.approx(1 * DEG)
    assert table.rake_max == pytest.approx(math.pi - soil.phi - soil.delta - 1 * DEG, abs=table.rake_step)
    rake = np.linspace(table.rake_min, table.rake_max, 20_011)  # off the grid points
    exact, looked_up = wedge_factors(rake, soil), table.lookup(rake)
    for field in ("beta", "n_gamma", "n_c", "n_q", "denominator"):
        np.testing.assert_allclose(getattr(looked_up, field), getattr(exact, field), rtol=1e-4, err_msg=field)
    # N_a changes sign (at rho + beta* + phi = 90 deg): its error is bounded against N_c's scale.
    scale = np.maximum(np.abs(exact.n_a), exact.n_c)
    assert np.max(np.abs(looked_up.n_a - exact.n_a) / scale) < 3e-4
    outside = table.lookup(np.array([0.5 * DEG, table.rake_max + 0.5 * DEG, np.nan]))
    assert np.all(np.isinf(outside.n_gamma)) and np.all(np.isnan(outside.beta))
    for array in (table.rake, table.beta, table.n_gamma, table.n_c, table.n_q, table.n_a, table.denominator):
        assert array.dtype == np.float64 and array.ndim == 1 and array.flags.c_contiguous and not array.flags.writeable


def test_table_for_another_soil_is_refused(sand_table):
    with pytest.raises(WedgeError, match="for_soil"):
        wedge_force(0.1, 0.5, get_soil("heavy_clay"), 0.3, table=sand_table)


def test_vectorized_calls_equal_scalar_loops(rng):
    loam = get_soil("sandy_loam")
    table = WedgeTable.for_soil(loam)
    d = rng.uniform(-0.05, 0.3, 100)
    rake = rng.uniform(2 * DEG, 110 * DEG, 100)
    for tab in (None, table):
        batch = wedge_force(d, rake, loam, 0.3, surcharge_pa=200.0, table=tab)
        loop = [wedge_force(float(a), float(b), loam, 0.3, surcharge_pa=200.0, table=tab) for a, b in zip(d, rake)]
        np.testing.assert_allclose(batch, loop, rtol=1e-14, atol=0)
    np.testing.assert_allclose(critical_beta(rake, loam.phi, loam.delta),
                               [critical_beta(float(r), loam.phi, loam.delta) for r in rake], rtol=1e-14)
    grid = wedge_force(d[:, None], rake[None, :7], loam, 0.3)
    assert grid.shape == (100, 7)
    np.testing.assert_allclose(grid[:, 3], wedge_force(d, rake[3], loam, 0.3), rtol=1e-14)


def test_force_direction_is_pi_2_minus_rho_minus_delta_backwards_and_down(rng):
    # The presets all have delta = phi; a smoother tool face (delta = 12 deg) keeps the two apart.
    smooth = get_soil("testbed_sand").model_copy(update={"tool_friction_angle_deg": 12.0})
    for soil in [get_soil(name) for name in SOILS] + [smooth]:
        rake = rng.uniform(5 * DEG, 60 * DEG, 50)
        d = rng.uniform(0.02, 0.3, 50)
        magnitude = wedge_force(d, rake, soil, 0.3)
        fx_tip, fz_tip = wedge_force_components(d, rake, soil, 0.3)
        fx, fz = wedge_force_components(d, rake, soil, 0.3, frame="plane")
        np.testing.assert_allclose(np.hypot(fx, fz), magnitude, rtol=1e-12)
        np.testing.assert_allclose(fx_tip, -magnitude * math.sin(soil.delta), rtol=1e-12)
        np.testing.assert_allclose(fz_tip, -magnitude * math.cos(soil.delta), rtol=1e-12)
        # The blade pushes the soil along (-fx, -fz): forwards (-X) and up, at pi/2 - rho - delta.
        np.testing.assert_allclose(np.arctan2(-fz, fx), force_angle(rake, soil.delta), atol=1e-12)
        np.testing.assert_allclose(np.arctan2(-fz, fx), 0.5 * math.pi - rake - soil.delta, atol=1e-12)
        down = rake + soil.delta < 0.5 * math.pi
        assert np.all(fx > 0) and np.all(fz[down] < 0)


def test_tip_frame_rotated_by_the_blade_gives_the_plane_frame(sand, rng):
    from excavsim.robot.statics import tip_force_in_plane

    rake = rng.uniform(5 * DEG, 110 * DEG, 50)
    fx_tip, fz_tip = wedge_force_components(0.1, rake, sand, 0.3)
    x_tip, z_tip = blade_axes(rake)
    plane = fx_tip[:, None] * x_tip + fz_tip[:, None] * z_tip
    np.testing.assert_allclose(np.stack(wedge_force_components(0.1, rake, sand, 0.3, frame="plane"), -1), plane,
                               rtol=1e-12)
    np.testing.assert_allclose(np.stack(tip_to_plane(fx_tip, fz_tip, rake), -1), plane, rtol=1e-12)
    # The same rotation as the statics' (x_tip at pi + rho, z_tip into the bucket).
    np.testing.assert_allclose(tip_force_in_plane(np.stack([fx_tip, fz_tip], -1), rake), plane, rtol=1e-12, atol=1e-9)
    # x_tip runs from the heel down to the cutting edge; z_tip is the unit normal towards the soil ahead (-X, up).
    np.testing.assert_allclose(np.sum(x_tip * z_tip, -1), 0.0, atol=1e-15)
    np.testing.assert_allclose(x_tip, np.stack([-np.cos(rake), -np.sin(rake)], -1), atol=1e-15)
    np.testing.assert_allclose(z_tip, np.stack([-np.sin(rake), np.cos(rake)], -1), atol=1e-15)


def test_force_with_adhesion_satisfies_the_wedge_equilibrium_of_eqs_3_and_4(rng):
    # Plane strain, unit width. In eqs. 3-4 x points along the travel and z down; in the plane frame X
    # points against the travel and Z up, so the blade's terms of eqs. 3-4 (its push on the wedge, in
    # (x, z)) are numerically the force on the blade in (X, Z).
    soil = get_soil("lean_clay").model_copy(update={"adhesion_pa": 4000.0, "tool_friction_angle_deg": 11.0})
    phi, delta, c, ca = soil.phi, soil.delta, soil.cohesion_pa, soil.adhesion_pa
    gamma_g = soil.density_kg_m3 * 9.81
    for _ in range(100):
        rho, d, q = rng.uniform(10, 120) * DEG, rng.uniform(0.02, 0.3), rng.uniform(0, 2000)
        beta = thesis_beta(rho, phi, delta)
        f = float(wedge_force(d, rho, soil, 1.0, surcharge_pa=q))
        lt, lf = d / math.sin(rho), d / math.sin(beta)
        weight = gamma_g * d**2 / 2 * (cot(rho) + cot(beta))  # eq. 6
        surcharge = q * d * (cot(rho) + cot(beta))  # eq. 7
        # eq. 3 gives R; eq. 4 must then balance.
        r = (f * math.sin(rho + delta) + ca * lt * math.cos(rho) - c * lf * math.cos(beta)) / math.sin(beta + phi)
        residual = (-f * math.cos(rho + delta) + ca * lt * math.sin(rho) - r * math.cos(beta + phi)
                    + c * lf * math.sin(beta) + weight + surcharge)
        assert abs(residual) < 1e-9 * (weight + surcharge + c * lf + ca * lt)
        fx, fz = wedge_force_components(d, rho, soil, 1.0, frame="plane", surcharge_pa=q)
        assert fx == pytest.approx(f * math.sin(rho + delta) + ca * lt * math.cos(rho), rel=1e-9)
        assert fz == pytest.approx(-f * math.cos(rho + delta) + ca * lt * math.sin(rho), rel=1e-9, abs=1e-9 * f)


def test_bad_arguments_are_refused_with_the_allowed_values(sand):
    with pytest.raises(WedgeError, match="width_m must be >= 0"):
        wedge_force(0.1, 0.5, sand, -0.3)
    with pytest.raises(WedgeError, match="surcharge_pa must be >= 0"):
        wedge_force(0.1, 0.5, sand, 0.3, surcharge_pa=-1.0)
    with pytest.raises(WedgeError, match="'tip' or 'plane'"):
        wedge_force_components(0.1, 0.5, sand, 0.3, frame="world")
    with pytest.raises(WedgeError, match="positive friction angle"):
        WedgeTable.build(0.0, 0.0)


def test_the_nominal_predictor_bears_in_full_what_the_bucket_cannot_take(sand, sand_table):
    """WedgePredictor's surcharge (eq. 7, Fig. 57): Q = s min(v, C) + max(v - C, 0), so beyond the
    capacity C every extra litre adds its whole weight over D, and below it only the share s."""
    from excavsim.planning.predictor import WedgePredictor

    s, cap, width, depth, rake = 0.3, 0.025, 0.3, 0.15, math.radians(40)
    pred = WedgePredictor(sand, width, surcharge_fraction=s, capacity_m3=cap, fill_weighted=False)
    blade_only = WedgePredictor(sand, width, surcharge_fraction=s, fill_weighted=False)

    def magnitude(p, v):
        return float(np.hypot(*p.predict(np.array([depth]), np.array([rake]), np.array([v]))[0]))

    d = wedge_denominator(rake, critical_beta(rake, sand.phi, sand.delta), sand.phi, sand.delta)
    gamma = sand.density_kg_m3 * G_M_S2
    assert magnitude(pred, 0.02) == pytest.approx(magnitude(blade_only, 0.02), rel=1e-12)  # room left
    assert magnitude(pred, 0.035) - magnitude(pred, 0.03) == pytest.approx(gamma * 0.005 / d, rel=1e-3)
    assert magnitude(blade_only, 0.035) - magnitude(blade_only, 0.03) == pytest.approx(s * gamma * 0.005 / d,
                                                                                        rel=1e-3)
    with pytest.raises(ValueError, match="capacity_m3 must be positive"):
        WedgePredictor(sand, width, capacity_m3=0.0)


def test_the_nominal_predictor_believes_the_worlds_fill_weighted_load_surcharge(sand):
    """The default WedgePredictor holds the world's law (kernels.load_surcharge_volume): the held soil
    h bears with the share h / C, Q = h^2 / C + max(v - C, 0); by hand at 15 cm and rho 40 deg."""
    from excavsim.planning.predictor import WedgePredictor
    from excavsim.world.kernels import load_surcharge_volume

    cap, width, depth, rake = 0.025, 0.3, 0.15, math.radians(40)
    pred = WedgePredictor(sand, width, capacity_m3=cap)
    d = wedge_denominator(rake, critical_beta(rake, sand.phi, sand.delta), sand.phi, sand.delta)
    gamma = sand.density_kg_m3 * G_M_S2
    blade = float(wedge_force(depth, rake, sand, width))
    for v in (0.005, 0.0125, 0.025, 0.03):
        got = float(np.hypot(*pred.predict(np.array([depth]), np.array([rake]), np.array([v]))[0]))
        held = min(v, cap)
        assert got == pytest.approx(blade + gamma * (held * held / cap + v - held) / d, rel=1e-3)
        if v <= cap:  # the same share as the world's
            assert held * held / cap == pytest.approx(load_surcharge_volume(v, cap))
    # a fifth full: a fifth of the 5 l bears (gamma g 1 l / D, about 22 N at rho 40 deg)
    one_litre = gamma * 0.001 / d
    assert one_litre == pytest.approx(21.7, abs=0.1)
