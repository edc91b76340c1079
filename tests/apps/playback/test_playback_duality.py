"""Dynamic impedance selection by the generalised duality principle (DiMaio 1998 §3.3.1,
eqs. 3.22-3.32, Figs. 3.7-3.10)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from excavsim.execution.duality import combined_error, error_paths, h2_norm_sq, optimal_damping

W_FIGS = 1e9  # the weighting at which Figs. 3.7-3.10's dampings (1-6 kN s/m) come out; the figures do not say theirs


def test_the_2_norm_of_eq_3_32_is_the_integral_of_eq_3_24():
    # hand check: ||1 / (s + a)||^2 = 1 / (2 a)
    assert h2_norm_sq([1.0], [1.0, 4.0]) == pytest.approx(1 / 8)
    # a filtered error path of eq. 3.22 against (1 / 2 pi) * integral |H(j w)|^2 dw
    num, den = error_paths(100.0, 2000.0, 25.0, 500.0, 4e4, 20.0)["x~/x0"]

    def mag2(w):
        return abs(np.polyval(num, 1j * w) / np.polyval(den, 1j * w)) ** 2

    integral = 2 * quad(mag2, 0, np.inf, limit=500)[0] / (2 * math.pi)
    assert h2_norm_sq(num, den) == pytest.approx(integral, rel=1e-6)
    with pytest.raises(ValueError):
        h2_norm_sq([1.0, 0.0], [1.0, 1.0])  # not strictly proper
    with pytest.raises(ValueError):
        h2_norm_sq([1.0], [1.0, -1.0])  # unstable


def test_the_error_paths_are_those_of_eqs_3_15_and_3_16():
    # at s = 0 (static), without the filter: x~ = x0 - x and f~ = f0 - Ke x with x from eq. 3.17
    mm, bm, km, be, ke, x0, f0 = 100.0, 2000.0, 1e4, 500.0, 3e4, 0.1, 2000.0
    p = error_paths(mm, bm, km, be, ke, 1.0)
    static = {k: np.polyval(n, 0) / np.polyval(d, 0) for k, (n, d) in p.items()}
    x = (f0 + km * x0) / (km + ke)
    assert static["x~/x0"] * x0 + static["x~/f0"] * f0 == pytest.approx(x0 - x)
    assert static["f~/x0"] * x0 + static["f~/f0"] * f0 == pytest.approx(f0 - ke * x)


def test_the_optimal_damping_follows_figs_3_7_to_3_10():
    def bm(mm=110.0, be=500.0, ke=39000.0, f3db=20.0):
        return optimal_damping(mm, be, ke, f3db_hz=f3db, w=W_FIGS)

    by_ke = [bm(ke=k) for k in (5e3, 1e4, 2e4, 4e4)]
    by_be = [bm(be=b) for b in (50.0, 200.0, 400.0, 600.0)]
    by_mm = [bm(mm=m) for m in (100.0, 300.0, 600.0, 900.0)]
    by_bw = [bm(mm=100.0, ke=1e4, f3db=f) for f in (1.0, 5.0, 20.0, 50.0, 100.0)]
    assert np.all(np.diff(by_ke) < 0)  # Fig. 3.7: falls with environment stiffness
    assert np.all(np.diff(by_be) < 0)  # Fig. 3.8: falls with environment damping
    assert np.all(np.diff(by_mm) > 0)  # §3.3.1: more machine mass demands more damping
    assert np.all(np.diff(by_bw) < 0)  # Fig. 3.10: falls with the desired trajectories' bandwidth
    assert 500.0 < by_ke[-1] < by_ke[0] < 10000.0  # the figures' kN s/m range
    b = bm()
    e = combined_error(110.0, b, W_FIGS / 39000.0, 500.0, 39000.0, f3db_hz=20.0, w=W_FIGS)
    for other in (0.5 * b, 2.0 * b):
        assert e < combined_error(110.0, other, W_FIGS / 39000.0, 500.0, 39000.0, f3db_hz=20.0, w=W_FIGS)
