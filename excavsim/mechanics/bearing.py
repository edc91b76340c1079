"""Bearing capacity of a strip footing: how hard the soil pushes back on the bucket's bottom and back.

Standard geotechnics, not from the thesis (which treats the bucket's bearing only qualitatively,
Singh 1995 Fig. 19): the world's soil model uses these factors for the pressure on the
bucket's outer surface, between the at-rest pressure and the bearing capacity.
"""

from __future__ import annotations

import math


def bearing_factors(phi: float) -> tuple[float, float, float]:
    """Strip-footing bearing capacity factors (N_c, N_q, N_gamma) for friction angle ``phi`` [rad].

    Prandtl-Reissner ``N_q = exp(pi tan phi) tan^2(pi/4 + phi/2)``, ``N_c = (N_q - 1) cot phi``
    (``2 + pi`` at phi = 0) and Vesic ``N_gamma = 2 (N_q + 1) tan phi``.
    """
    t = math.tan(phi)
    n_q = math.exp(math.pi * t) * math.tan(math.pi / 4 + phi / 2) ** 2
    n_c = (n_q - 1) / t if phi > 1e-9 else 2 + math.pi
    n_g = 2 * (n_q + 1) * t
    return n_c, n_q, n_g
