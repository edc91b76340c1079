"""Dynamic impedance selection by the generalised duality principle (DiMaio 1998 §3.3.1,
"Dynamic Impedance Selection: A State-Space Approach", eqs. 3.22-3.32, Figs. 3.7-3.10).

The machine (eq. 3.15) ``Mm s^2 x = f0 + fe - (Bm s + Km)(x - x0)`` against a first-order environment
(eq. 3.16) ``fe = -(Be s + Ke) x`` gives, with ``D(s) = Mm s^2 + (Bm + Be) s + (Km + Ke)`` (eq. 3.35),
the position error ``x~ = x0 - x`` and the force error ``f~ = f0 - (Be s + Ke) x`` (eqs. 3.22-3.23):

    x~ = [(Mm s^2 + Be s + Ke) x0 - f0] / D
    f~ = [(Mm s^2 + Bm s + Km) f0 - (Be s + Ke)(Bm s + Km) x0] / D

Both desired signals pass a first-order filter of bandwidth f3dB (eq. 3.26) so that every path is
strictly proper; each path's 2-norm (eq. 3.24, the RMS response to white noise) is computed from its
controller-canonical state-space form (eqs. 3.28-3.31) with the controllability Gramian (eq. 3.32:
``||H||^2 = C P C^T`` with ``A P + P A^T + B B^T = 0``), and the combined error is eq. 3.25,
``E = W ||x~||^2 + ||f~||^2`` (both inputs unit-intensity white noise, one per desired signal: the
thesis does not give their intensities, **assumed**). As in §3.3.1, E is minimised over the damping
``Bm`` only, with ``Mm`` fixed and ``Km`` from the static duality (eq. 3.21, ``Km = W / Ke``) -- the thesis
used MatLab's Newton search; here a bounded scalar search over ``log Bm``.

The chapter-6 controllers do not use this online (nor did the thesis: §3.3.4 replaces it by the
force/velocity ratio, since identifying ``Be`` and ``Ke`` separately in real time was not possible); it
is the analysis behind them, checked against Figs. 3.7-3.10's trends in the tests and plotted by
``excavsim playback`` (``duality.png``).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import solve_continuous_lyapunov
from scipy.optimize import minimize_scalar


def h2_norm_sq(num, den) -> float:
    """The squared 2-norm (eq. 3.24) of the strictly proper transfer function ``num / den`` (coefficients,
    highest power first), from its controller-canonical form and the controllability Gramian (eq. 3.32).

    Raises:
        ValueError: not strictly proper, or not stable (the Gramian would not exist).
    """
    den = np.trim_zeros(np.asarray(den, dtype=float), "f")
    num = np.trim_zeros(np.asarray(num, dtype=float), "f")
    n = len(den) - 1
    if len(num) > n:
        raise ValueError(f"h2_norm_sq: num {num} over den {den} is not strictly proper")
    if num.size == 0:
        return 0.0
    a = den[1:] / den[0]
    if np.any(np.roots(den).real >= 0):
        raise ValueError(f"h2_norm_sq: den {den} is not stable")
    A = np.zeros((n, n))
    A[0, :] = -a
    A[1:, :-1] = np.eye(n - 1)
    B = np.zeros((n, 1))
    B[0, 0] = 1.0
    C = np.zeros((1, n))
    C[0, n - len(num):] = num / den[0]
    P = solve_continuous_lyapunov(A, -B @ B.T)
    return float((C @ P @ C.T)[0, 0])


def error_paths(mm: float, bm: float, km: float, be: float, ke: float, f3db_hz: float) -> dict[str, tuple]:
    """The four filtered error paths (eqs. 3.22-3.23 with eq. 3.26's filter): ``{"x~/x0", "x~/f0", "f~/x0",
    "f~/f0"}`` -> (num, den) polynomial coefficients, highest power first."""
    wc = 2.0 * math.pi * f3db_hz
    den = np.polymul([mm, bm + be, km + ke], [1.0, wc])
    paths = {"x~/x0": [mm, be, ke], "x~/f0": [-1.0], "f~/x0": np.polymul([-be, -ke], [bm, km]),
             "f~/f0": [mm, bm, km]}
    return {k: (wc * np.asarray(v, dtype=float), den) for k, v in paths.items()}


def combined_error(mm: float, bm: float, km: float, be: float, ke: float, *, f3db_hz: float, w: float) -> float:
    """Eq. 3.25: ``E = W ||x~||^2 + ||f~||^2`` over unit white noise on both desired signals."""
    p = {k: h2_norm_sq(*v) for k, v in error_paths(mm, bm, km, be, ke, f3db_hz).items()}
    return w * (p["x~/x0"] + p["x~/f0"]) + p["f~/x0"] + p["f~/f0"]


def optimal_damping(mm: float, be: float, ke: float, *, f3db_hz: float, w: float, km: float | None = None,
                    bounds: tuple[float, float] = (1.0, 1.0e6)) -> float:
    """The machine damping ``Bm`` [N s/m] minimising eq. 3.25 (§3.3.1), with ``Km = W / Ke`` (eq. 3.21)
    unless given and ``Mm`` fixed."""
    km = w / ke if km is None else km
    lo, hi = math.log(bounds[0]), math.log(bounds[1])
    res = minimize_scalar(lambda lb: combined_error(mm, math.exp(lb), km, be, ke, f3db_hz=f3db_hz, w=w),
                          bounds=(lo, hi), method="bounded", options={"xatol": 1e-4})
    return float(math.exp(res.x))
