"""Classical passive earth pressure: the published closed forms the wedge model must reproduce.

The wedge model (:mod:`excavsim.mechanics.wedge`, Singh 1995 eqs. 3-11) is Coulomb's
passive wedge: a planar failure surface through the tip, its angle the one of least resistance. For
a cohesionless soil with a horizontal surface and no surcharge, the force on a blade of rake ``rho``
is therefore Coulomb's passive thrust on a wall whose back face is inclined ``theta = pi/2 - rho``
from the vertical, leaning under the soil it retains (the wedge then holds the triangle
``d^2 cot(rho) / 2`` above the face, as eq. 6's ``cot rho`` term does)::

    P_p = 1/2 gamma g d^2 K_p      so that      N_gamma = K_p / 2

with Mueller-Breslau's (1906) closed form of Coulomb's passive coefficient for a wall batter
``theta``, wall friction ``delta`` and backfill slope ``i`` (as printed in geotechnical texts, e.g.
Das, *Principles of Foundation Engineering*, "Coulomb's passive earth pressure")::

    K_p = cos^2(phi + theta) / { cos^2(theta) cos(delta - theta)
                                 [1 - sqrt( sin(phi + delta) sin(phi + i) / (cos(delta - theta) cos(i - theta)) )]^2 }

and, for a smooth vertical wall (``delta = theta = i = 0``), Rankine's ``K_p = tan^2(pi/4 + phi/2)``
with Bell's (1915) cohesion term ``2 c d sqrt(K_p)``, i.e. ``N_c = 2 sqrt(K_p)``. These are
references for tests, not used by the world or the planner.
"""

from __future__ import annotations

import numpy as np

from excavsim.errors import SoilModelError


def coulomb_passive_coefficient(phi, delta, theta=0.0, backfill=0.0) -> np.ndarray:
    """Coulomb's passive earth pressure coefficient ``K_p`` in Mueller-Breslau's closed form.

    Args:
        phi: soil friction angle [rad], > 0.
        delta: wall (tool) friction angle [rad], >= 0.
        theta: inclination of the wall's back face from the vertical [rad], positive when it leans
            under the retained soil (a blade of rake ``rho`` has ``theta = pi/2 - rho``).
        backfill: slope of the soil surface above the horizontal [rad].
        All broadcast.

    Returns:
        ``K_p`` in the broadcast shape; the passive thrust is ``gamma g d^2 K_p / 2`` per unit width
        at ``delta`` from the wall's normal. NaN where the closed form is 0/0 (``phi + theta = pi/2``
        with ``i = 0``: a wall lying along the failure plane's conjugate; its limit is finite).

    Raises:
        ExcavsimError: ``phi`` not positive or ``delta`` negative.
    """
    phi, delta, theta, i = (np.asarray(v, dtype=float) for v in (phi, delta, theta, backfill))
    if np.any(phi <= 0) or np.any(delta < 0):
        raise SoilModelError(f"Coulomb's K_p needs phi > 0 and delta >= 0 [rad]; given phi min {phi.min()!r}, "
                             f"delta min {delta.min()!r}")
    with np.errstate(divide="ignore", invalid="ignore"):
        root = np.sqrt(np.sin(phi + delta) * np.sin(phi + i) / (np.cos(delta - theta) * np.cos(i - theta)))
        return (np.cos(phi + theta) ** 2 / (np.cos(theta) ** 2 * np.cos(delta - theta) * (1.0 - root) ** 2))[()]


def rankine_passive_coefficient(phi) -> np.ndarray:
    """Rankine's passive coefficient ``tan^2(pi/4 + phi/2)`` (smooth vertical wall, level surface)."""
    phi = np.asarray(phi, dtype=float)
    return (np.tan(np.pi / 4 + phi / 2) ** 2)[()]
