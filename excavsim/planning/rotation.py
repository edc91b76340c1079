"""Rotation centres of a bucket that rotates while it translates ("drag", Singh 1995 §3.4.2.3).

During the drag the tip B moves horizontally towards the robot while the pitch falls by ``omega``
per metre travelled (eq. 1). The instantaneous centre of rotation lies on the perpendicular to B's
motion (Fig. 17), the vertical through B, at the distance ``1 / omega`` above it: a tip moving at
unit speed with the pitch falling at ``omega`` per unit distance turns clockwise about that point.

Reuleaux's construction (§3.4.2.1, Figs. 15-16, 21) bounds the admissible centres: for the bottom of
the bucket to move away from the soil below it, the centre must not lie closer to the tip than the
point where the normal to the bottom at its far end A meets the vertical through B. With the bottom a
straight segment of length ``L`` from the tip at pitch ``rho`` (A = B + L (cos rho, sin rho), outer
normal n = (sin rho, -cos rho)), a centre C = B + (0, h) moves A along ``n`` only while
``n x (A - C) = L - h sin rho`` is negative, so the closest admissible centre is ``h = L / sin rho``
above the tip: it grows without bound as the pitch falls (Fig. 22's dashed line). The pitch at which
the two meet is the smallest rake the drag may reach for that rate, ``zeta(omega) =
arcsin(L omega)`` (eq. 1's zeta). Simplification: the bottom is taken as the straight blade only
(the thesis' segment AB), not the arc and back of the bucket.
"""

from __future__ import annotations

import numpy as np

from excavsim.errors import ConfigError


def drag_rotation_radius(omega_rad_per_m) -> np.ndarray:
    """Distance from the tip to the instantaneous rotation centre, ``1 / omega`` [m] (Fig. 22's solid
    lines); ``omega`` the fall of the pitch per metre of drag [rad/m], > 0."""
    omega = np.asarray(omega_rad_per_m, dtype=float)
    if np.any(omega <= 0):
        raise ConfigError(f"the rate of rotation must be > 0 rad/m; given min {omega.min()!r}")
    return (1.0 / omega)[()]


def closest_admissible_radius(bottom_length_m: float, pitch_rad) -> np.ndarray:
    """The closest admissible rotation centre's distance above the tip, ``L / sin rho`` [m] (Fig. 22's
    dashed line); ``inf`` for a pitch at or below 0 (no centre keeps a flat bottom off the soil)."""
    if not bottom_length_m > 0:
        raise ConfigError(f"the bucket's bottom length must be > 0 m; given {bottom_length_m!r}")
    s = np.sin(np.asarray(pitch_rad, dtype=float))
    with np.errstate(divide="ignore"):
        return np.where(s > 0, bottom_length_m / np.where(s > 0, s, 1.0), np.inf)[()]


def minimum_drag_rake(bottom_length_m: float, omega_rad_per_m) -> np.ndarray:
    """``zeta(omega) = arcsin(L omega)`` [rad]: the pitch below which rotating at ``omega`` presses the
    bottom into the soil (eq. 1); NaN where ``L omega > 1`` (no pitch up to 90 deg is admissible)."""
    omega = np.asarray(omega_rad_per_m, dtype=float)
    drag_rotation_radius(omega)  # checks omega
    if not bottom_length_m > 0:
        raise ConfigError(f"the bucket's bottom length must be > 0 m; given {bottom_length_m!r}")
    x = bottom_length_m * omega
    with np.errstate(invalid="ignore"):
        return np.where(x <= 1.0, np.arcsin(np.minimum(x, 1.0)), np.nan)[()]
