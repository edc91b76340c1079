"""The inertial term of the dynamic Fundamental Equation of Earthmoving (McKyes 1985), as a reference.

The wedge model of Singh 1995 (eqs. 3-11, :mod:`excavsim.mechanics.wedge`) is static:
"At low speeds, the forces required to accelerate soil in front of the blade can be ignored"
(§5.1.2). Its dynamic form (McKyes, *Soil Cutting and Tillage*, 1985, ch. 4) adds the force that
accelerates the soil entering the wedge::

    F = (gamma g d^2 N_gamma + c d N_c + q d N_q + gamma v^2 d N_acc) w

Derivation (the same equilibrium as eqs. 3-4): a blade advancing at ``v`` takes in soil at the mass
rate ``gamma v d w`` (``gamma`` the density). The wedge slides along the blade face and, relative to
the soil at rest, along the failure plane, so its velocity is along the failure plane with magnitude
``v sin rho / sin(rho + beta)`` (the velocity triangle of blade, face and failure plane). The force
that gives the incoming soil this velocity, ``F_a = gamma v^2 d w sin rho / sin(rho + beta)`` along
the failure plane, enters eqs. 3-4 beside ``W + Q``; solving for the blade force gives the increment
``F_a cos phi / sin(rho + delta + phi + beta)``, i.e.::

    N_acc = sin rho cos phi / ( sin(rho + beta) sin(rho + delta + phi + beta) )
          = [tan beta + cot(beta + phi)]
            / ( [cos(rho + delta) + sin(rho + delta) cot(beta + phi)] (1 + tan beta cot rho) )

the second line being McKyes' form. Simplification: evaluated at the static critical angle beta*
(the minimum of ``N_gamma``), as the static factors are; the soil is rigid and enters the wedge at
the blade's speed. The world's soil model adds this term to its wedge force
(:mod:`excavsim.world.soil`, tabulated per rake by ``acceleration_factor``); the planner's model
stays static (eq. 8).
"""

from __future__ import annotations

import numpy as np

from excavsim.config import SoilParams
from excavsim.errors import SoilModelError
from excavsim.mechanics.wedge import critical_beta


def acceleration_factor(rake, beta, phi, delta) -> np.ndarray:
    """``N_acc`` of the dynamic earthmoving equation at failure angle ``beta`` (all [rad], broadcasting);
    ``inf`` where no wedge exists (``rho + delta + phi + beta >= pi``)."""
    rake, beta, phi, delta = (np.asarray(v, dtype=float) for v in (rake, beta, phi, delta))
    s_a = np.sin(rake + delta + phi + beta)
    with np.errstate(divide="ignore", invalid="ignore"):
        n = np.sin(rake) * np.cos(phi) / (np.sin(rake + beta) * s_a)
    return np.where((s_a > 0) & (rake + delta + phi + beta < np.pi), n, np.inf)[()]


def inertial_force(depth_m, rake, speed_m_s, soil: SoilParams, width_m) -> np.ndarray:
    """The blade force that accelerates the soil, ``gamma v^2 d N_acc w`` at the static beta* [N].

    Args:
        depth_m: cutting depth [m] (0 force where <= 0); rake: [rad]; speed_m_s: blade speed [m/s];
            soil: density and friction angles; width_m: blade width [m]. All broadcast.

    Raises:
        ExcavsimError: a negative speed or width.
    """
    depth_m, rake, v, w = (np.asarray(x, dtype=float) for x in (depth_m, rake, speed_m_s, width_m))
    if np.any(v < 0) or np.any(w < 0):
        raise SoilModelError(f"speed_m_s and width_m must be >= 0; given min {v.min()!r}, {w.min()!r}")
    beta = critical_beta(rake, soil.phi, soil.delta)
    n_acc = acceleration_factor(rake, beta, soil.phi, soil.delta)
    force = soil.density_kg_m3 * v**2 * np.maximum(depth_m, 0.0) * n_acc * w
    return np.where(depth_m > 0, force, 0.0)[()]
