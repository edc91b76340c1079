r"""The wedge model of a flat blade cutting soil: the Fundamental Equation of Earthmoving.

Singh 1995 §5.1.2.1, eqs. 3-11 (after [McKyes85], [Reece64]). A flat blade of width
``w`` at depth ``d`` and rake ``rho`` pushes a triangular wedge of soil up a planar failure surface
at angle ``beta``; the force the blade must apply at the moment the wedge fails is (eqs. 5, 8)::

    F = (gamma g d^2 N_gamma + c d N_c + q d N_q + c_a d N_a) w,    at pi/2 - rho - delta from horizontal

with the N factors of eqs. 9-11 and ``beta`` the angle that minimizes ``N_gamma`` (Coulomb; Fig. 56).
Eq. 8 drops the adhesion term of eq. 5; it is kept here as ``N_a = [1 - cot rho cot(beta + phi)] / D``
and vanishes for every preset in ``configs/soils.yaml`` (``adhesion_pa = 0``).

Simplifications of the model (the thesis' caveats, §5.1.2.1):

* static: no force to accelerate the soil, no rate effects (eq. 3-4 are equilibria; §5.1.3.3);
* planar failure surface (the true one is closer to a logarithmic spiral), its angle fixed by the
  minimum of ``N_gamma`` alone, independent of cohesion and surcharge;
* uniform surcharge ``q`` over the wedge (eq. 7), although displaced soil piles up near the blade;
* plane strain: an infinitely wide, flat blade moving horizontally at constant depth through a flat,
  unconfined (no dilation) soil; the width only multiplies (eq. 8); only the state just before failure.

Geometry and signs (the arm plane: X horizontal, pointing opposite to the direction of travel; Z up)::

        -d cot(beta)                  +d cot(rho)
     ______._____________________________.______   soil surface, Z = 0
            \                           /
             \      wedge: W + Q       /
     failure  \                     /    blade face (inside of the bucket),
     plane at  \                 /       rake rho from the horizontal
     beta       \             /
                 \         /                      travel: towards -X
                  \     /
                   tip (X = 0, Z = -d)

The blade runs from the tip up and back (+X) at ``rho`` from the horizontal: ``rho = 90 deg`` is a
vertical blade, a small rake a blade lying nearly flat. The force the blade applies to the wedge is
its normal reaction along the face normal ``n = (-sin rho, cos rho)`` plus the friction ``tan delta``
opposing the soil riding up the face, i.e. along ``(-cos rho, -sin rho)``; their resultant is
``F (-sin(rho + delta), cos(rho + delta))`` -- forwards and upwards at ``pi/2 - rho - delta`` from
the horizontal (eq. 8's angle; eqs. 3-4 with z downward). The soil therefore pushes on the blade with::

    plane frame (X opposite to travel, Z up):   F ( sin(rho + delta), -cos(rho + delta) )
    tip frame (x heel -> cutting edge along the blade, z the face normal into the bucket):
                                                F ( -sin(delta), -cos(delta) )

backwards and downwards while ``rho + delta < 90 deg``. In the plane, ``x_tip = (-cos rho, -sin rho)``
and ``z_tip = (-sin rho, cos rho)`` (:func:`blade_axes`); projecting the plane form on them gives the
tip form. With adhesion the blade also feels the shear ``c_a L_t w`` along ``-x_tip``, with
``L_t = d / sin rho``; :func:`wedge_force_components` includes it, :func:`wedge_force` (the magnitude
``F`` of eq. 5) does not.

Closed forms used here (identities of eqs. 9-11, ``A = rho + delta + phi``)::

    D       = cos(rho + delta) + sin(rho + delta) cot(beta + phi) = sin(A + beta) / sin(beta + phi)
    N_gamma = sin(rho + beta) sin(beta + phi) / (2 sin rho sin beta sin(A + beta));   N_q = 2 N_gamma
    N_c     = cos phi / (sin beta sin(A + beta));   N_a = -cos(rho + beta + phi) / (sin rho sin(A + beta))

A wedge exists only while ``D > 0``, i.e. ``beta < pi - A``; so the rake must lie in
``(0, pi - phi - delta)`` (120 deg for the testbed sand). Where it does not, the factors are ``inf``.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Literal, NamedTuple

import numpy as np

from excavsim.config import SoilParams
from excavsim.errors import WedgeError

G_M_S2 = 9.81  # gravitational acceleration [m/s^2]
# Below this rake the blade slices along itself, outside the wedge model: the world and the
# predictors hold the factors at their value here.
MIN_RAKE_RAD = math.radians(5.0)


class WedgeFactors(NamedTuple):
    """The wedge at the critical failure angle, for one rake or an array of rakes.

    Attributes:
        beta: critical failure-plane angle from horizontal [rad] (NaN where no wedge exists).
        n_gamma, n_c, n_q, n_a: the N factors of eqs. 9-11 and the adhesion factor (inf where none).
        denominator: ``D`` of eqs. 5, 9-11 (0 where no wedge exists).
    """

    beta: np.ndarray
    n_gamma: np.ndarray
    n_c: np.ndarray
    n_q: np.ndarray
    n_a: np.ndarray
    denominator: np.ndarray


def _as_float(*xs) -> tuple[np.ndarray, ...]:
    return tuple(np.broadcast_arrays(*(np.asarray(x, dtype=np.float64) for x in xs)))


def wedge_denominator(rake, beta, phi, delta) -> np.ndarray:
    """``D = cos(rho + delta) + sin(rho + delta) cot(beta + phi)`` of eqs. 5 and 9-11 (broadcasting).

    ``F D`` balances the wedge's weight, surcharge, cohesion and adhesion; ``D <= 0`` means the
    blade cannot fail the wedge (no finite force). All angles [rad]; returns the broadcast shape.
    """
    rake, beta, phi, delta = _as_float(rake, beta, phi, delta)
    return (np.sin(rake + delta + phi + beta) / np.sin(beta + phi))[()]


def n_factors(rake, beta, phi, delta) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The N factors of eqs. 9-11 and the adhesion factor of eq. 5 at a given failure angle.

    Args:
        rake: blade rake angle rho from horizontal [rad], in (0, pi).
        beta: failure-plane angle from horizontal [rad], in (0, pi/2].
        phi: soil internal friction angle [rad].
        delta: soil-tool friction angle [rad].
        All four broadcast against each other.

    Returns:
        ``(N_gamma, N_c, N_q, N_a)`` in the broadcast shape; ``inf`` where the geometry is impossible
        (rake or beta out of range, or ``D <= 0``).
    """
    rake, beta, phi, delta = _as_float(rake, beta, phi, delta)
    a = rake + delta + phi
    s_ab = np.sin(a + beta)
    ok = (rake > 0) & (rake < np.pi) & (beta > 0) & (beta <= 0.5 * np.pi) & (s_ab > 0) & (beta + phi < np.pi)
    with np.errstate(divide="ignore", invalid="ignore"):
        s_r, s_b = np.sin(rake), np.sin(beta)
        n_gamma = np.sin(rake + beta) * np.sin(beta + phi) / (2.0 * s_r * s_b * s_ab)
        n_c = np.cos(phi) / (s_b * s_ab)
        n_a = -np.cos(rake + beta + phi) / (s_r * s_ab)
    out = [np.where(ok, n, np.inf)[()] for n in (n_gamma, n_c, 2.0 * n_gamma, n_a)]
    return out[0], out[1], out[2], out[3]


def critical_beta(rake, phi, delta) -> np.ndarray:
    """The failure-plane angle that minimizes ``N_gamma`` (Fig. 56), in closed form.

    ``ln N_gamma`` is stationary where ``sin rho sin(A + beta) sin(beta + phi) = sin(rho + delta)
    sin(rho + beta) sin beta``; with product-to-sum identities this is ``P cos 2beta + R sin 2beta =
    -sin delta`` with ``P = sin rho cos(2phi + rho + delta) - sin(rho + delta) cos rho`` and
    ``R = sin rho [sin(rho + delta) - sin(2phi + rho + delta)]``, whose two roots are compared.
    The minimum is always interior: ``N_gamma`` grows without bound as ``beta -> 0`` and as
    ``beta -> pi - A``, and where ``beta = pi/2`` is feasible (``A < pi/2``) its slope there,
    ``cot rho sin(rho + delta) / cos^2 phi - cos(A) / cos phi`` (times ``1 / 2D^2``), is positive for
    ``phi > 0``, ``delta >= 0``.

    Args:
        rake, phi, delta: as in :func:`n_factors` [rad], broadcasting; ``phi > 0`` (for ``phi = 0``
            the infimum is at ``beta -> 0`` and NaN is returned).

    Returns:
        beta* [rad] in (0, pi/2), broadcast shape; NaN where no wedge exists (``rake >= pi - phi - delta``).
    """
    rake, phi, delta = _as_float(rake, phi, delta)
    p = np.sin(rake) * np.cos(2 * phi + rake + delta) - np.sin(rake + delta) * np.cos(rake)
    r = np.sin(rake) * (np.sin(rake + delta) - np.sin(2 * phi + rake + delta))
    h = np.hypot(p, r)
    with np.errstate(divide="ignore", invalid="ignore"):
        half_width = np.arccos(np.clip(-np.sin(delta) / h, -1.0, 1.0))
    psi = np.arctan2(r, p)
    roots = np.stack([np.mod(0.5 * (psi + half_width), np.pi), np.mod(0.5 * (psi - half_width), np.pi)])
    n_gamma = n_factors(rake, roots, phi, delta)[0]
    n_gamma = np.where(np.isnan(n_gamma), np.inf, n_gamma)
    best = np.argmin(n_gamma, axis=0)
    beta = np.take_along_axis(roots, best[None], axis=0)[0]
    finite = np.isfinite(np.take_along_axis(n_gamma, best[None], axis=0)[0]) & (phi > 0)
    return np.where(finite, beta, np.nan)[()]


def _exact_factors(rake, phi: float, delta: float) -> WedgeFactors:
    beta = critical_beta(rake, phi, delta)
    n_gamma, n_c, n_q, n_a = n_factors(rake, beta, phi, delta)
    with np.errstate(invalid="ignore"):
        d = np.where(np.isfinite(n_gamma), wedge_denominator(rake, beta, phi, delta), 0.0)[()]
    return WedgeFactors(beta, n_gamma, n_c, n_q, n_a, d)


@dataclasses.dataclass(frozen=True, eq=False)
class WedgeTable:
    """Critical angle and N factors of one soil, tabulated on a uniform rake grid.

    Valid rakes are ``[rake_min, rake_max]``: from 1 deg (N factors grow like ``1/rho`` towards a
    flat blade) to 1 deg short of ``pi - phi - delta``, where ``D -> 0`` and the factors grow like
    ``1/(pi - phi - delta - rho)^2`` (119 deg for the testbed sand). The arrays are plain read-only
    float64 numpy arrays of shape ``(n,)`` so that a compiled kernel can interpolate in them:
    ``u = (rake - rake_min) / rake_step``, ``i = floor(u)``, linear between ``i`` and ``i + 1``.
    With the default 0.01 deg step linear interpolation is within ``1e-4`` relative of the exact
    ``beta``, ``N_gamma``, ``N_c``, ``N_q`` and ``D`` over the whole valid range, the worst at its ends;
    ``N_a``, which changes sign, within ``3e-4 max(|N_a|, N_c)`` (tests/mechanics/test_wedge.py).

    Attributes:
        phi, delta: the soil's friction angles the table was built for [rad].
        rake_step: grid spacing [rad].
        rake: (n,) grid rakes [rad]; ``rake[0] = rake_min``, ``rake[-1] = rake_max``.
        beta, n_gamma, n_c, n_q, n_a, denominator: (n,) the exact values at the grid rakes.
    """

    phi: float
    delta: float
    rake_step: float
    rake: np.ndarray
    beta: np.ndarray
    n_gamma: np.ndarray
    n_c: np.ndarray
    n_q: np.ndarray
    n_a: np.ndarray
    denominator: np.ndarray

    @property
    def rake_min(self) -> float:
        """Smallest tabulated rake [rad]."""
        return float(self.rake[0])

    @property
    def rake_max(self) -> float:
        """Largest tabulated rake [rad]."""
        return float(self.rake[-1])

    @classmethod
    def build(cls, phi: float, delta: float, *, rake_step: float = math.radians(0.01),
              margin: float = math.radians(1.0)) -> WedgeTable:
        """Tabulate the exact factors for friction angles ``phi``, ``delta`` [rad].

        Args:
            rake_step: grid spacing [rad].
            margin: distance kept from both ends of ``(0, pi - phi - delta)`` [rad].

        Raises:
            WedgeError: ``phi`` is not positive, or no rake range is left.
        """
        if not phi > 0:
            raise WedgeError(f"the wedge model needs a positive friction angle phi; given {phi!r} rad")
        hi = min(math.pi - phi - delta, math.pi) - margin
        n = int(math.floor((hi - margin) / rake_step + 1e-9)) + 1
        if n < 2:
            raise WedgeError(f"no rake range is left for phi={phi:.4g}, delta={delta:.4g} rad with margin "
                             f"{margin:.4g} rad; allowed: phi + delta + 2 margin < pi")
        rake = margin + rake_step * np.arange(n)
        f = _exact_factors(rake, phi, delta)
        arrays = {name: np.ascontiguousarray(v, dtype=np.float64) for name, v in zip(f._fields, f, strict=True)}
        for v in (rake, *arrays.values()):
            v.setflags(write=False)
        return cls(float(phi), float(delta), float(rake_step), rake, **arrays)

    @classmethod
    def for_soil(cls, soil: SoilParams, **kwargs) -> WedgeTable:
        """The table for ``soil``'s friction angles (keyword arguments as in :meth:`build`)."""
        return cls.build(soil.phi, soil.delta, **kwargs)

    def lookup(self, rake) -> WedgeFactors:
        """Factors at ``rake`` [rad] (any shape) by linear interpolation on the grid.

        Outside ``[rake_min, rake_max]`` (and for NaN) the N factors are ``inf``, ``beta`` NaN and
        ``denominator`` 0: clip the rake first if a finite (if large) answer is wanted there.
        """
        rake = np.asarray(rake, dtype=np.float64)
        n = self.rake.shape[0]
        u = (rake - self.rake[0]) / self.rake_step
        inside = (u >= -1e-9) & (u <= n - 1 + 1e-9)
        i = np.clip(np.floor(np.nan_to_num(u)), 0, n - 2).astype(np.intp)
        t = u - i

        def interp(v: np.ndarray, outside: float) -> np.ndarray:
            lo = v[i]
            return np.where(inside, lo + t * (v[i + 1] - lo), outside)[()]

        return WedgeFactors(interp(self.beta, np.nan), interp(self.n_gamma, np.inf), interp(self.n_c, np.inf),
                            interp(self.n_q, np.inf), interp(self.n_a, np.inf), interp(self.denominator, 0.0))


def wedge_factors(rake, soil: SoilParams, table: WedgeTable | None = None) -> WedgeFactors:
    """Critical angle and factors for ``soil`` at ``rake`` [rad]: exact, or from ``table`` if given.

    Raises:
        WedgeError: ``table`` was built for other friction angles than ``soil``'s.
    """
    if table is None:
        return _exact_factors(rake, soil.phi, soil.delta)
    if not (math.isclose(table.phi, soil.phi, abs_tol=1e-12) and math.isclose(table.delta, soil.delta, abs_tol=1e-12)):
        raise WedgeError(f"the table was built for phi={math.degrees(table.phi):.4g} deg, delta="
                         f"{math.degrees(table.delta):.4g} deg but the soil has phi={soil.friction_angle_deg} deg, "
                         f"delta={soil.tool_friction_angle_deg} deg; build it with WedgeTable.for_soil(soil)")
    return table.lookup(rake)


def wedge_force(depth_m, rake, soil: SoilParams, width_m, *, surcharge_pa=0.0, surcharge_volume_m3=0.0,
                table: WedgeTable | None = None) -> np.ndarray:
    """Magnitude of the blade force at failure, eq. 8 plus eq. 5's adhesion term [N].

    ``F = (gamma g d^2 N_gamma + c d N_c + q d N_q + c_a d N_a) w + gamma g V / D``. The factors are
    evaluated at the rake's critical failure angle, exactly or from ``table``.

    Args:
        depth_m: cutting depth d [m]; the force is 0 where ``d <= 0``.
        rake: rake angle rho [rad].
        soil: density, cohesion, adhesion and friction angles.
        width_m: blade width w [m], >= 0.
        surcharge_pa: uniform surcharge pressure q on the wedge [Pa] (eq. 7), >= 0.
        surcharge_volume_m3: soil resting on the wedge, given as a volume over the whole width [m^3]
            (see :func:`surcharge_force`), >= 0.
        table: a :class:`WedgeTable` for ``soil``; ``None`` computes beta* exactly.
        All array arguments broadcast.

    Returns:
        F [N] in the broadcast shape; ``inf`` where no wedge exists (or outside the table's range).

    Raises:
        WedgeError: a negative width or surcharge, or a table for another soil.
    """
    depth_m, rake, width_m, q, vol = _as_float(depth_m, rake, width_m, surcharge_pa, surcharge_volume_m3)
    for name, v in (("width_m", width_m), ("surcharge_pa", q), ("surcharge_volume_m3", vol)):
        if np.any(v < 0):
            raise WedgeError(f"{name} must be >= 0; given min {v.min()!r}")
    f = wedge_factors(rake, soil, table)
    gamma_g = soil.density_kg_m3 * G_M_S2
    d = np.maximum(depth_m, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        per_width = gamma_g * d**2 * f.n_gamma + soil.cohesion_pa * d * f.n_c + q * d * f.n_q
        if soil.adhesion_pa:
            per_width = per_width + soil.adhesion_pa * d * f.n_a
        force = per_width * width_m + np.where(vol > 0, gamma_g * vol / f.denominator, 0.0)
    force = np.where(np.isfinite(f.n_gamma), force, np.inf)  # no wedge: 0 * inf terms would give NaN
    return np.where(depth_m > 0, force, 0.0)[()]


def surcharge_force(volume_m3, rake, soil: SoilParams, *, table: WedgeTable | None = None) -> np.ndarray:
    """Blade force due to a volume of soil resting on the wedge [N] (eqs. 7-8, Fig. 57).

    ``q d N_q w = Q w / D``: the surcharge term is the weight of the surcharge soil over the wedge
    divided by ``D``, however that soil is spread, so a displaced volume ``V`` contributes
    ``gamma g V / D(rho, beta*)``. It does not depend on the depth.

    Args:
        volume_m3: soil on the wedge, over the whole blade width [m^3], >= 0.
        rake: rake angle rho [rad]; broadcasts with ``volume_m3``.
        soil: supplies density and friction angles.
        table: optional :class:`WedgeTable` for ``soil``.

    Returns:
        Force [N] in the broadcast shape; ``inf`` where no wedge exists (for a positive volume).
    """
    volume_m3, rake = _as_float(volume_m3, rake)
    if np.any(volume_m3 < 0):
        raise WedgeError(f"volume_m3 must be >= 0; given min {volume_m3.min()!r}")
    f = wedge_factors(rake, soil, table)
    weight = soil.density_kg_m3 * G_M_S2 * volume_m3
    with np.errstate(divide="ignore", invalid="ignore"):
        force = np.where(f.denominator > 0, weight / f.denominator, np.inf)
    return np.where(volume_m3 > 0, force, 0.0)[()]


def force_angle(rake, delta) -> np.ndarray:
    """Angle of the blade force from the horizontal, ``pi/2 - rho - delta`` [rad] (eq. 8)."""
    rake, delta = _as_float(rake, delta)
    return (0.5 * np.pi - rake - delta)[()]


def blade_axes(rake) -> tuple[np.ndarray, np.ndarray]:
    """The tip frame's axes in the arm plane (X opposite to travel, Z up).

    Returns:
        ``(x_tip, z_tip)``, each of shape ``rake.shape + (2,)``: ``x_tip = (-cos rho, -sin rho)`` runs
        along the blade from heel to cutting edge, ``z_tip = (-sin rho, cos rho)`` is the face normal
        into the bucket (towards the soil being cut).
    """
    rake = np.asarray(rake, dtype=np.float64)
    c, s = np.cos(rake), np.sin(rake)
    return np.stack([-c, -s], axis=-1), np.stack([-s, c], axis=-1)


def tip_to_plane(fx_tip, fz_tip, rake) -> tuple[np.ndarray, np.ndarray]:
    """Rotate tip-frame components into the arm plane: ``f = fx x_tip + fz z_tip``; returns ``(fX, fZ)``."""
    fx_tip, fz_tip, rake = _as_float(fx_tip, fz_tip, rake)
    c, s = np.cos(rake), np.sin(rake)
    return (-c * fx_tip - s * fz_tip)[()], (-s * fx_tip + c * fz_tip)[()]


def wedge_force_components(depth_m, rake, soil: SoilParams, width_m, *, frame: Literal["tip", "plane"] = "tip",
                           surcharge_pa=0.0, surcharge_volume_m3=0.0,
                           table: WedgeTable | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The force the soil exerts on the blade, in the tip frame or the arm plane [N].

    ``frame="tip"``: ``(f_x, f_z)`` with x along the blade from heel to cutting edge and z the face
    normal into the bucket; ``F (-sin delta, -cos delta)`` plus the adhesion shear ``-c_a (d / sin rho) w``
    in x. ``frame="plane"``: ``(f_X, f_Z)`` with X horizontal opposite to the travel and Z up; without
    adhesion ``F (sin(rho + delta), -cos(rho + delta))``. Arguments as in :func:`wedge_force`.

    Raises:
        WedgeError: an unknown ``frame``, or as :func:`wedge_force`.
    """
    if frame not in ("tip", "plane"):
        raise WedgeError(f"frame must be 'tip' or 'plane'; given {frame!r}")
    force = wedge_force(depth_m, rake, soil, width_m, surcharge_pa=surcharge_pa,
                        surcharge_volume_m3=surcharge_volume_m3, table=table)
    depth_m, rake, width_m = _as_float(depth_m, rake, width_m)
    fx = -force * math.sin(soil.delta)
    fz = -force * math.cos(soil.delta)
    if soil.adhesion_pa:
        fx = fx - soil.adhesion_pa * np.maximum(depth_m, 0.0) / np.sin(rake) * width_m
    return tip_to_plane(fx, fz, rake) if frame == "plane" else (fx[()], fz[()])
