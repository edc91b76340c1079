"""The truth of the 2-D loading world (Singh 1995 §7.2.1): a pile's profile on flat ground.

The world is a vertical section: columns of soil of width ``dx`` [m] on the ground at z = 0, column i
centred at ``x0 + (i + 1/2) dx``, height ``heights[i]`` [m]. Areas are in m^2 of the section;
:data:`UNIT_M2` is the "unit of soil" of §7.2.1 (the thesis does not say what its unit is; we take
0.01 m^2, a 10 cm x 10 cm square of the section, so the loader's 48 units are 0.48 m^2, about a
2.5 m^3 bucket 5 m wide; assumed).

* :meth:`Pile2D.carve`: the bucket's path (a polyline below which nothing stays) is removed exactly:
  every column whose centre lies within the path's x range is lowered to the path's height there, and
  the area removed is the sum of what each column lost (the planner's swept area is computed the same
  way on the same columns, so the two agree to round-off);
* :meth:`Pile2D.settle`: relaxation to the angle of repose (§2.1.2's sand-pile model in one
  dimension): until no step between neighbouring columns exceeds ``dx tan(repose)``, each too-steep
  pair shares the excess so that the step is exactly at repose; the total area is conserved;
* :func:`random_pile`: a pile for a seed: a few overlapping heaps of random heights and widths, settled,
  scaled to a given area.

Numbers in, numbers out: the world knows nothing of machines or plans.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from excavsim.errors import ConfigError

UNIT_M2 = 0.01  # one "unit of soil" of §7.2.1 [m^2 of the section] (assumed, see the module docstring)


@numba.njit(cache=True)
def _relax(h, step, tol, max_sweeps):
    """In-place Gauss-Seidel relaxation of column heights ``h`` to steps of at most ``step`` [m]; sweeps used."""
    n = h.size
    for sweep in range(max_sweeps):
        moved = 0.0
        if sweep % 2 == 0:
            lo, hi, inc = 0, n - 1, 1
        else:
            lo, hi, inc = n - 2, -1, -1
        i = lo
        while i != hi:
            d = h[i + 1] - h[i]
            if d > step + tol:
                m = 0.5 * (d - step)
                h[i + 1] -= m
                h[i] += m
                moved += m
            elif -d > step + tol:
                m = 0.5 * (-d - step)
                h[i] -= m
                h[i + 1] += m
                moved += m
            i += inc
        if moved == 0.0:
            return sweep + 1
    return max_sweeps


class Pile2D:
    """A pile's profile on flat ground (see the module docstring).

    Args:
        heights: (n,) column heights [m], >= 0.
        dx: column width [m]; x0: the left edge of column 0 [m].
        repose_deg: the soil's angle of repose [deg], in (0, 90).
    """

    def __init__(self, heights, dx: float, x0: float = 0.0, repose_deg: float = 35.0):
        h = np.array(heights, dtype=float)
        if h.ndim != 1 or h.size < 2:
            raise ConfigError(f"pile heights must be a 1-D array of at least 2 columns; given shape {h.shape}")
        if not np.all(np.isfinite(h)) or np.any(h < 0):
            raise ConfigError("pile heights must be finite and >= 0 m")
        if not (math.isfinite(dx) and dx > 0):
            raise ConfigError(f"column width dx must be > 0 m; given {dx!r}")
        if not (0.0 < repose_deg < 90.0):
            raise ConfigError(f"angle of repose must lie in (0, 90) degrees; given {repose_deg!r}")
        self.heights = h
        self.dx = float(dx)
        self.x0 = float(x0)
        self.repose_deg = float(repose_deg)

    @property
    def xs(self) -> np.ndarray:
        """(n,) column centres [m]."""
        return self.x0 + (np.arange(self.heights.size) + 0.5) * self.dx

    def area(self) -> float:
        """Soil in the section [m^2]."""
        return float(self.heights.sum() * self.dx)

    def foot(self, tol: float = 1e-3) -> float:
        """The x of the pile's near foot: the left edge of the first column higher than ``tol`` [m] (inf if none)."""
        idx = np.nonzero(self.heights > tol)[0]
        return math.inf if idx.size == 0 else self.x0 + idx[0] * self.dx

    def carve(self, path_x, path_z) -> float:
        """Remove what lies above a bucket path (a polyline, x increasing) over its x range; the area removed [m^2].

        Columns whose centre lies in [path_x[0], path_x[-1]] drop to the path's height there (linear between
        the path's points) where it is below them.
        """
        px = np.asarray(path_x, dtype=float)
        pz = np.asarray(path_z, dtype=float)
        if px.ndim != 1 or px.shape != pz.shape or px.size < 2:
            raise ConfigError("a bucket path needs matching 1-D x and z of at least 2 points")
        if not (np.all(np.isfinite(px)) and np.all(np.isfinite(pz))) or np.any(np.diff(px) < 0):
            raise ConfigError("a bucket path must be finite with x non-decreasing")
        xs = self.xs
        sel = (xs >= px[0]) & (xs <= px[-1])
        cut = np.interp(xs[sel], px, pz)
        new = np.minimum(self.heights[sel], np.maximum(cut, 0.0))
        removed = float(((self.heights[sel] - new) * self.dx).sum())
        self.heights[sel] = new
        return removed

    def settle(self, tol: float = 1e-9, max_sweeps: int = 100_000) -> int:
        """Relax to the angle of repose in place (see the module docstring); sweeps used."""
        return int(_relax(self.heights, self.dx * math.tan(math.radians(self.repose_deg)), tol, max_sweeps))

    def copy(self) -> Pile2D:
        return Pile2D(self.heights.copy(), self.dx, self.x0, self.repose_deg)


def trapezoid_pile(height: float, top: float, foot: float, width: float, dx: float, repose_deg: float) -> Pile2D:
    """A pile of ``height`` [m] with a flat ``top`` [m] and faces at repose, its near foot at x = ``foot``,
    in a section ``width`` [m] wide from x = 0."""
    if not (height > 0 and top >= 0 and foot >= 0 and width > 0):
        raise ConfigError("a trapezoid pile needs height > 0, top >= 0, foot >= 0 and width > 0")
    run = height / math.tan(math.radians(repose_deg))
    if foot + 2 * run + top > width:
        raise ConfigError(f"a pile {2 * run + top:.2f} m wide at its base from x = {foot} m does not fit "
                          f"a section {width} m wide")
    n = int(round(width / dx))
    xs = (np.arange(n) + 0.5) * dx
    rise = (xs - foot) / run * height
    fall = (foot + 2 * run + top - xs) / run * height
    h = np.clip(np.minimum(np.minimum(rise, fall), height), 0.0, None)
    return Pile2D(h, dx, 0.0, repose_deg)


def random_pile(seed: int, area_m2: float, *, foot: float, width: float, dx: float, repose_deg: float,
                heaps: int = 4) -> Pile2D:
    """A randomly generated pile for ``seed``: ``heaps`` heaps, settled to repose, scaled to ``area_m2``.

    Each heap is a trapezoid at repose with a random top (0 to 1.5 m) and height (1 to 2.5 m), its foot a
    uniform draw in the first third of the pile's span; their union (the highest at each column) is
    settled, then every column scaled so that the section holds ``area_m2`` [m^2], and settled again.
    The pile's near foot is at ``foot`` [m] (assumed generator; the thesis says only "randomly generated").
    """
    if not (area_m2 > 0 and math.isfinite(area_m2)):
        raise ConfigError(f"pile area must be > 0 m^2; given {area_m2!r}")
    if not (0 <= seed < 2 ** 32):
        raise ConfigError(f"seed must lie in 0 to 2^32 - 1; given {seed!r}")
    rng = np.random.default_rng(seed)
    n = int(round(width / dx))
    xs = (np.arange(n) + 0.5) * dx
    tan_r = math.tan(math.radians(repose_deg))
    span = width - foot
    h = np.zeros(n)
    for i in range(heaps):
        height = rng.uniform(1.0, 2.5)
        top = rng.uniform(0.0, 1.5)
        start = foot if i == 0 else foot + rng.uniform(0.0, span / 3)
        run = height / tan_r
        rise = (xs - start) * tan_r
        fall = (start + 2 * run + top - xs) * tan_r
        h = np.maximum(h, np.clip(np.minimum(np.minimum(rise, fall), height), 0.0, None))
    pile = Pile2D(h, dx, 0.0, repose_deg)
    pile.settle()
    total = pile.area()
    if total <= 0:
        raise ConfigError("random pile: the heaps hold no soil")
    pile.heights *= area_m2 / total
    pile.settle()
    if pile.heights[-1] > 1e-6:
        raise ConfigError(f"random pile: {area_m2} m^2 does not fit a section {width} m wide")
    return pile
