"""Soil settlement: relax the heightfield until no slope between neighbours exceeds the angle of repose.

This is Puhl's method for a single-valued soil surface, modified for an arbitrary angle of repose
(Singh 1995 §2.1.2, Fig. 6: the banks of a trench settle to 30 degrees). The grid is
``heights: (nrow, ncol) float64, metres``, ``heights[row, col]`` with ``row`` the y index and ``col``
the x index, on square cells of side ``cell_size_m``; each sample is a soil column of area
``cell_size_m**2``. Each cell has 8 neighbours, at ``L = cell`` (axis) and ``L = sqrt(2) cell``
(diagonal). The surface is stable when ``h_i - h_j <= tan(repose) L + tolerance`` for every pair.
The grid borders are walls: no soil leaves the grid, so the volume is conserved to round-off.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from numba import njit

from excavsim.errors import SoilModelError

# 1 / (n + 1) for n = 0..8 receivers: the water level of a cell and its n receivers (see _relax_sweeps).
_INV_N_PLUS_1 = 1.0 / np.arange(1.0, 10.0)
# Stay strictly below the reverse-flow bound of the over-relaxation (see _relax_sweeps).
_NO_BACKFLOW = 1.999


@dataclasses.dataclass(frozen=True)
class SettleResult:
    """What one call of :func:`settle` did.

    Attributes:
        iterations: sweeps that moved soil (the last sweep, which found nothing to move, is not counted).
        converged: ``residual_excess_m <= tolerance``.
        residual_excess_m: largest remaining excess of a height difference over ``tan(repose) L`` [m],
            measured after stopping over the cells the settle visited and a one-cell ring around them
            (the whole grid when no region was given); negative when every slope there is below repose.
        moved_volume_m3: total volume moved between cells (sum of all transfers times ``cell**2``) [m^3].
    """

    iterations: int
    converged: bool
    residual_excess_m: float
    moved_volume_m3: float


def settle(
    heights: np.ndarray,
    cell_size_m: float,
    repose_rad: float,
    *,
    tolerance_m: float = 1e-3,
    max_iterations: int = 400,
    region: tuple[int, int, int, int] | None = None,
    over_relaxation: float = 1.5,
) -> SettleResult:
    """Let the soil surface slide until no slope exceeds the angle of repose, in place.

    Soil flows from a cell to those of its 8 neighbours it stands above by more than
    ``tan(repose) L + tolerance_m``; each such cell is lowered to exactly the angle of repose with the
    neighbours it feeds (the least-squares move that fixes all of its outflow at once, so no
    neighbour is favoured). Sweeps over the grid alternate their direction and continue until a sweep
    finds nothing to move, or ``max_iterations`` sweeps have moved soil. Volume is conserved to
    round-off and no soil crosses the grid border. Terrain whose slopes are all within the tolerance
    is left unchanged bit for bit.

    Each cell's outflow may be over-relaxed by ``over_relaxation`` ``w``: the move is scaled by
    ``1 + min(w - 1, 1.999 tan(repose) cell / excess)``, which never lifts a receiver so far that soil
    would flow back. The trade-off, on the trench of ``excavsim bench settle`` (121 x 121 cells of
    2.5 cm, a 1.2 x 0.3 x 0.4 m trench, repose 30 deg, tolerance 1 mm): w = 1.0 needs 100 sweeps,
    w = 1.5 54 and w = 1.8 37; the mirror asymmetry of the settled trench (the sweep order breaks
    symmetry, and which of the many stable surfaces is reached depends on the order) grows from
    3.4 mm at w = 1 to 4.3 mm at w = 1.5 and 6.2 mm at w = 1.8, out of a repose step of 14 mm per
    cell. The default 1.5 halves the sweeps for 1 mm more asymmetry; use 1.0 when symmetry matters
    more than speed. A smaller tolerance also reduces the asymmetry and
    the slope error (slopes may stand ``tolerance_m / L`` steeper than repose), at the cost of sweeps.

    Args:
        heights: ``(nrow, ncol)`` float64, C-contiguous, writeable: the soil surface [m]; modified in place.
        cell_size_m: side of a grid cell [m].
        repose_rad: angle of repose [rad], in (0, pi/2).
        tolerance_m: excess of a height difference over ``tan(repose) L`` that is accepted as stable [m].
        max_iterations: cap on the sweeps that move soil; 0 only measures the residual.
        region: ``(row0, row1, col0, col1)``, half-open: the cells where the terrain just changed.
            Relaxation starts there (and at the cells around it) and spreads only as far as soil
            actually moves, so when the rest of the terrain is stable within the tolerance the result
            is identical to a whole-grid settle and costs a small fraction of it. ``None``: the whole grid.
        over_relaxation: ``w`` in [1, 2), see above.

    Returns:
        A :class:`SettleResult`.

    Raises:
        ValueError: ``heights`` is not a 2-D float64 C-contiguous writeable array of finite values,
            or a scalar argument or the region is out of range.
    """
    _check_heights(heights)
    _check_positive_finite("cell_size_m", cell_size_m)
    _check_positive_finite("tolerance_m", tolerance_m)
    if not (isinstance(repose_rad, (int, float, np.floating)) and 0.0 < repose_rad < 0.5 * math.pi):
        raise SoilModelError(f"repose_rad must lie in (0, pi/2) radians, got {repose_rad!r}")
    if not (isinstance(over_relaxation, (int, float, np.floating)) and 1.0 <= over_relaxation < 2.0):
        raise SoilModelError(f"over_relaxation must lie in [1, 2), got {over_relaxation!r}")
    if isinstance(max_iterations, bool) or not isinstance(max_iterations, (int, np.integer)) or max_iterations < 0:
        raise SoilModelError(f"max_iterations must be a whole number >= 0, got {max_iterations!r}")
    nrow, ncol = heights.shape
    row0, row1, col0, col1 = (0, nrow, 0, ncol) if region is None else _check_region(region, heights.shape)

    s_axis = math.tan(repose_rad) * cell_size_m
    s_diag = s_axis * math.sqrt(2.0)
    # dirty_from[i]: the first sweep in which cell i must be looked at; -1 = not dirty.
    dirty_from = np.full(heights.shape, -1, dtype=np.int32)
    if region is not None:
        # The cells around the change see a new neighbour too: start one ring wider.
        row0, row1, col0, col1 = max(row0 - 1, 0), min(row1 + 1, nrow), max(col0 - 1, 0), min(col1 + 1, ncol)
    dirty_from[row0:row1, col0:col1] = 0
    sweeps, moved_height_m, residual = _relax_sweeps(
        heights, dirty_from, s_axis, s_diag, float(tolerance_m), int(max_iterations), float(over_relaxation),
        row0, row1, col0, col1,
    )
    return SettleResult(
        iterations=int(sweeps),
        converged=bool(residual <= tolerance_m),
        residual_excess_m=float(residual),
        moved_volume_m3=float(moved_height_m) * cell_size_m**2,
    )


def max_slope_excess(heights: np.ndarray, cell_size_m: float, repose_rad: float) -> float:
    """Largest excess of a neighbour height difference over ``tan(repose) L``, over all 8-neighbour pairs.

    The reference check of :func:`settle`, written independently of it with whole-array operations.

    Args:
        heights: ``(nrow, ncol)`` heights [m].
        cell_size_m: side of a grid cell [m].
        repose_rad: angle of repose [rad].

    Returns:
        ``max |h_i - h_j| - tan(repose) L_ij`` [m]: <= 0 when the surface is stable, ``-inf`` when the
        grid has no neighbour pairs (a single cell).
    """
    h = np.asarray(heights, dtype=np.float64)
    if h.ndim != 2:
        raise SoilModelError(f"heights must be 2-D (nrow, ncol), got shape {h.shape}")
    s_axis = math.tan(repose_rad) * cell_size_m
    s_diag = s_axis * math.sqrt(2.0)
    pairs = (
        (h[:, 1:], h[:, :-1], s_axis),  # along a row (x)
        (h[1:, :], h[:-1, :], s_axis),  # along a column (y)
        (h[1:, 1:], h[:-1, :-1], s_diag),  # diagonal
        (h[1:, :-1], h[:-1, 1:], s_diag),  # anti-diagonal
    )
    worst = -math.inf
    for a, b, s in pairs:
        if a.size:
            worst = max(worst, float(np.abs(a - b).max()) - s)
    return worst


def _check_heights(heights: object) -> None:
    """Raise ValueError unless ``heights`` can be settled in place."""
    if not isinstance(heights, np.ndarray):
        raise SoilModelError(f"heights must be a numpy array (it is modified in place), got {type(heights).__name__}")
    if heights.ndim != 2:
        raise SoilModelError(f"heights must be 2-D (nrow, ncol), got shape {heights.shape}")
    if heights.dtype != np.float64 or not heights.flags.c_contiguous or not heights.flags.writeable:
        raise SoilModelError(
            f"heights must be a writeable float64 C-contiguous array because it is settled in place; got dtype "
            f"{heights.dtype}, C-contiguous {heights.flags.c_contiguous}, writeable {heights.flags.writeable}. "
            "Pass np.ascontiguousarray(heights, dtype=np.float64) and keep that array."
        )
    if heights.size == 0:
        raise SoilModelError(f"heights must have at least one cell, got shape {heights.shape}")
    if not np.isfinite(heights).all():
        bad = np.argwhere(~np.isfinite(heights))[0]
        raise SoilModelError(f"heights must be finite; heights[{bad[0]}, {bad[1]}] = {heights[tuple(bad)]}")


def _check_positive_finite(name: str, value: object) -> None:
    """Raise ValueError unless ``value`` is a finite number > 0."""
    if not (isinstance(value, (int, float, np.floating, np.integer)) and not isinstance(value, bool)
            and math.isfinite(value) and value > 0):
        raise SoilModelError(f"{name} must be a finite number > 0, got {value!r}")


def _check_region(region: object, shape: tuple[int, int]) -> tuple[int, int, int, int]:
    """The region as four ints, or ValueError unless it is a half-open box inside the grid."""
    nrow, ncol = shape
    allowed = f"allowed: (row0, row1, col0, col1) with 0 <= row0 < row1 <= {nrow} and 0 <= col0 < col1 <= {ncol}"
    if (not isinstance(region, (tuple, list)) or len(region) != 4
            or not all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) for v in region)):
        raise SoilModelError(f"region must be four whole numbers (row0, row1, col0, col1), got {region!r}; {allowed}")
    row0, row1, col0, col1 = (int(v) for v in region)
    if not (0 <= row0 < row1 <= nrow and 0 <= col0 < col1 <= ncol):
        raise SoilModelError(f"region {tuple(region)} is empty or does not fit the {nrow} x {ncol} grid; {allowed}")
    return row0, row1, col0, col1


@njit(cache=True)
def _window_excess(h, s_axis, s_diag, r0, r1, c0, c1):
    """:func:`max_slope_excess` over the pairs inside ``h[r0:r1, c0:c1]``, without temporaries."""
    worst = -np.inf
    for r in range(r0, r1):
        for c in range(c0, c1):
            hi = h[r, c]
            if c + 1 < c1:
                worst = max(worst, abs(hi - h[r, c + 1]) - s_axis)
            if r + 1 < r1:
                worst = max(worst, abs(hi - h[r + 1, c]) - s_axis)
                if c + 1 < c1:
                    worst = max(worst, abs(hi - h[r + 1, c + 1]) - s_diag)
                if c > c0:
                    worst = max(worst, abs(hi - h[r + 1, c - 1]) - s_diag)
    return worst


@njit(cache=True, inline="always")
def _water_level(e0, e1, e2, e3, e4, e5, e6, e7):
    """Drop ``T`` of a cell that feeds its neighbours: the root of ``T = sum_k max(e_k - T, 0)``.

    Lowering the cell by ``T`` and raising each neighbour with ``e_k > T`` by ``e_k - T`` leaves it at
    exactly the angle of repose with all of them: the smallest squared move that makes every
    outflow pair stable. Found by dropping the neighbours at or below the level until none is left.
    """
    n = 0
    total = 0.0
    for e in (e0, e1, e2, e3, e4, e5, e6, e7):
        if e > 0.0:
            n += 1
            total += e
    level = total * _INV_N_PLUS_1[n]
    while True:
        n_new = 0
        total = 0.0
        for e in (e0, e1, e2, e3, e4, e5, e6, e7):
            if e > level:
                n_new += 1
                total += e
        if n_new == n:
            return level
        n = n_new
        level = total * _INV_N_PLUS_1[n]


@njit(cache=True)
def _relax_sweeps(h, dirty_from, s_axis, s_diag, tol, max_sweeps, w, r0, r1, c0, c1):
    """Gauss-Seidel sweeps over the dirty cells until one moves nothing; see :func:`settle`.

    ``dirty_from`` holds per cell the first sweep that must look at it: a cell is looked at in sweep k
    when ``dirty_from >= k``, and a cell that gives soil marks its 8 neighbours for the next sweep,
    which also makes them visited later in the current one. The window to loop over grows during a
    sweep to every marked cell ahead in the sweep order, so that a region settle makes exactly the
    moves a whole-grid settle would make.

    Returns:
        ``(sweeps that moved soil, sum of transfers [m of height], residual excess [m])``, the residual
        over the box of the cells visited or changed and the ring around it, whose pairs with them
        are the only ones that can have changed.
    """
    nrow, ncol = h.shape
    hf = h.ravel()
    df = dirty_from.ravel()
    wall = np.inf
    moved = 0.0
    sweep = 0
    # Box of everything visited or marked, for the residual.
    t_r0, t_r1, t_c0, t_c1 = r0, r1 - 1, c0, c1 - 1
    while sweep < max_sweeps and r0 < r1 and c0 < c1:
        # Alternate the four directions so that no side is favoured for long.
        order = sweep & 3
        rows_fwd = order == 0 or order == 2
        cols_fwd = order == 0 or order == 3
        nxt = sweep + 1
        m_r0, m_r1, m_c0, m_c1 = nrow, -1, ncol, -1  # box of the cells marked in this sweep
        moved_now = False
        r = r0 if rows_fwd else r1 - 1
        while True:
            if rows_fwd:
                if r > max(r1 - 1, m_r1):
                    break
            elif r < min(r0, m_r0):
                break
            up = r > 0
            down = r < nrow - 1
            base = r * ncol
            c_lo = min(c0, m_c0)
            c_hi = max(c1 - 1, m_c1)
            c = c_lo if cols_fwd else c_hi
            while c_lo <= c <= c_hi:
                i = base + c
                c_here = c
                c = c + 1 if cols_fwd else c - 1
                if df[i] < sweep:
                    continue
                left = c_here > 0
                right = c_here < ncol - 1
                hi = hf[i]
                # Neighbour heights; +inf across a wall, which therefore never receives.
                h0 = hf[i - ncol - 1] if up and left else wall
                h1 = hf[i - ncol] if up else wall
                h2 = hf[i - ncol + 1] if up and right else wall
                h3 = hf[i - 1] if left else wall
                h4 = hf[i + 1] if right else wall
                h5 = hf[i + ncol - 1] if down and left else wall
                h6 = hf[i + ncol] if down else wall
                h7 = hf[i + ncol + 1] if down and right else wall
                # The largest excess over repose comes from the lowest axis or diagonal neighbour
                # (exactly: rounding is monotone), so stable cells cost two subtractions.
                e_max = max(hi - min(min(h1, h3), min(h4, h6)) - s_axis, hi - min(min(h0, h2), min(h5, h7)) - s_diag)
                if e_max <= tol:
                    continue
                e0 = hi - h0 - s_diag
                e1 = hi - h1 - s_axis
                e2 = hi - h2 - s_diag
                e3 = hi - h3 - s_axis
                e4 = hi - h4 - s_axis
                e5 = hi - h5 - s_diag
                e6 = hi - h6 - s_axis
                e7 = hi - h7 - s_diag
                level = _water_level(e0, e1, e2, e3, e4, e5, e6, e7)
                # Over-relax, but keep every receiver below the donor's new level + tan L: the
                # reverse excess after the move is g e_k - 2 tan L_k, which this bound keeps negative.
                g = min(w - 1.0, _NO_BACKFLOW * s_axis / e_max)
                q = 1.0 + g
                total = 0.0
                for e, j in ((e0, i - ncol - 1), (e1, i - ncol), (e2, i - ncol + 1), (e3, i - 1),
                             (e4, i + 1), (e5, i + ncol - 1), (e6, i + ncol), (e7, i + ncol + 1)):
                    if e > level:
                        f = (e - level) * q
                        hf[j] += f
                        total += f
                hf[i] = hi - total
                moved += total
                moved_now = True
                # The donor went down: its neighbours may now flow into it, the receivers onwards.
                ra = r - 1 if up else r
                rb = r + 1 if down else r
                ca = c_here - 1 if left else c_here
                cb = c_here + 1 if right else c_here
                for rr in range(ra, rb + 1):
                    for cc in range(ca, cb + 1):
                        df[rr * ncol + cc] = nxt
                m_r0 = min(m_r0, ra)
                m_r1 = max(m_r1, rb)
                m_c0 = min(m_c0, ca)
                m_c1 = max(m_c1, cb)
                c_lo = min(c_lo, ca)
                c_hi = max(c_hi, cb)
            r = r + 1 if rows_fwd else r - 1
        if not moved_now:
            break
        sweep += 1
        r0, r1, c0, c1 = m_r0, m_r1 + 1, m_c0, m_c1 + 1
        t_r0 = min(t_r0, m_r0)
        t_r1 = max(t_r1, m_r1)
        t_c0 = min(t_c0, m_c0)
        t_c1 = max(t_c1, m_c1)
    residual = _window_excess(h, s_axis, s_diag, max(t_r0 - 1, 0), min(t_r1 + 2, nrow), max(t_c0 - 1, 0),
                              min(t_c1 + 2, ncol))
    return sweep, moved, residual
