"""Exact, compiled ray casting against the soil heightfield and the box's walls and targets.

MuJoCo's ``mj_multiRay`` is too slow for ten 40,000-ray scans per map on the soil heightfield
(``excavsim bench sensing`` times both, side by side). This module intersects rays with the same surface
analytically: the heightfield is MuJoCo's triangulation (each grid square split along the diagonal
from sample (r, c) to (r + 1, c + 1), verified against ``mj_ray`` in the tests), traversed cell by
cell along the ray (Amanatides-Woo), and boxes (walls, target plates) by the slab method. A test
keeps ``mj_multiRay`` as the reference.

Grid conventions are those of :class:`excavsim.world.terrain.SoilGrid`.
"""

from __future__ import annotations

import numba
import numpy as np

HIT_NONE, HIT_SOIL, HIT_BOX = 0, 1, 2


@numba.njit(cache=True, inline="always")
def _surface_tri(h, r, c, fu, fv, upper):
    """Height on a chosen triangle of cell (r, c) (``upper``: the fu >= fv one), extended linearly."""
    h00 = h[r, c]
    h11 = h[r + 1, c + 1]
    if upper:
        return h00 + fu * (h[r, c + 1] - h00) + fv * (h11 - h[r, c + 1])
    return h00 + fv * (h[r + 1, c] - h00) + fu * (h11 - h[r + 1, c])


@numba.njit(cache=True, inline="always")
def _normal(h, r, c, fu, fv, cell):
    """Unnormalized upward normal of the triangle under (fu, fv) in cell (r, c)."""
    if fu >= fv:
        dzdx = (h[r, c + 1] - h[r, c]) / cell
        dzdy = (h[r + 1, c + 1] - h[r, c + 1]) / cell
    else:
        dzdx = (h[r + 1, c + 1] - h[r + 1, c]) / cell
        dzdy = (h[r + 1, c] - h[r, c]) / cell
    return -dzdx, -dzdy, 1.0


@numba.njit(cache=True)
def _ray_hfield(h, x0, y0, cell, z0, ztop, ox, oy, oz, dx, dy, dz, tmax):
    """First hit of a ray with the heightfield: (t, nx, ny, nz) or (inf, 0, 0, 0)."""
    nr, nc = h.shape
    x1 = x0 + (nc - 1) * cell
    y1 = y0 + (nr - 1) * cell
    # clip to the heightfield's bounding box
    t0, t1 = 0.0, tmax
    for o, d, lo, hi in ((ox, dx, x0, x1), (oy, dy, y0, y1), (oz, dz, z0 - 1e-9, ztop)):
        if abs(d) < 1e-15:
            if o < lo or o > hi:
                return np.inf, 0.0, 0.0, 0.0
        else:
            ta = (lo - o) / d
            tb = (hi - o) / d
            if ta > tb:
                ta, tb = tb, ta
            t0 = max(t0, ta)
            t1 = min(t1, tb)
    if t0 > t1:
        return np.inf, 0.0, 0.0, 0.0
    # walk the cells the ray's xy projection crosses
    px = (ox + t0 * dx - x0) / cell
    py = (oy + t0 * dy - y0) / cell
    c = min(max(int(np.floor(px)), 0), nc - 2)
    r = min(max(int(np.floor(py)), 0), nr - 2)
    step_c = 1 if dx > 0 else -1
    step_r = 1 if dy > 0 else -1
    inv_dx = cell / abs(dx) if abs(dx) > 1e-15 else np.inf
    inv_dy = cell / abs(dy) if abs(dy) > 1e-15 else np.inf
    next_c = (c + (1 if dx > 0 else 0)) * cell + x0
    next_r = (r + (1 if dy > 0 else 0)) * cell + y0
    tx = (next_c - ox) / dx if abs(dx) > 1e-15 else np.inf
    ty = (next_r - oy) / dy if abs(dy) > 1e-15 else np.inf
    ta = t0
    while ta <= t1:
        tb = min(tx, ty, t1)
        # inside cell (r, c) for t in [ta, tb]; split at the diagonal fu = fv
        fu_a = (ox + ta * dx - x0) / cell - c
        fv_a = (oy + ta * dy - y0) / cell - r
        fu_b = (ox + tb * dx - x0) / cell - c
        fv_b = (oy + tb * dy - y0) / cell - r
        ga = fu_a - fv_a
        gb = fu_b - fv_b
        tm = tb
        if ga * gb < 0.0:
            tm = ta + (tb - ta) * ga / (ga - gb)
        s0, s1 = ta, tm
        for _ in range(2):
            if s1 >= s0:
                fua = (ox + s0 * dx - x0) / cell - c
                fva = (oy + s0 * dy - y0) / cell - r
                fub = (ox + s1 * dx - x0) / cell - c
                fvb = (oy + s1 * dy - y0) / cell - r
                # the sub-interval lies in one triangle: the one under its midpoint
                fum = 0.5 * (fua + fub)
                fvm = 0.5 * (fva + fvb)
                upper = fum >= fvm
                za = _surface_tri(h, r, c, fua, fva, upper)
                zb = _surface_tri(h, r, c, fub, fvb, upper)
                fa = oz + s0 * dz - z0 - za
                fb = oz + s1 * dz - z0 - zb
                if fa >= 0.0 and fb <= 0.0 and fa - fb > 0.0:
                    t = s0 + (s1 - s0) * fa / (fa - fb)
                    nx, ny, nz = _normal(h, r, c, fum, fvm, cell)
                    return t, nx, ny, nz
                if fa < 0.0 and s0 == t0:  # starts below the surface (inside the soil)
                    return s0, 0.0, 0.0, 1.0
            s0, s1 = tm, tb
        if tb >= t1:
            break
        if tx < ty:
            c += step_c
            tx += inv_dx
        else:
            r += step_r
            ty += inv_dy
        if c < 0 or c > nc - 2 or r < 0 or r > nr - 2:
            break
        ta = tb
    return np.inf, 0.0, 0.0, 0.0


@numba.njit(cache=True)
def _ray_boxes(boxes, ox, oy, oz, dx, dy, dz, tmax):
    """First hit with oriented boxes (rows: centre 3, rotation 9 row-major, half sizes 3)."""
    best = tmax
    bn = np.zeros(3)
    hit = False
    for k in range(boxes.shape[0]):
        cx, cy, cz = boxes[k, 0], boxes[k, 1], boxes[k, 2]
        rot = boxes[k, 3:12]
        # ray in the box frame: R^T (o - c), R^T d
        qx, qy, qz = ox - cx, oy - cy, oz - cz
        lo_ = np.empty(3)
        ld = np.empty(3)
        for a in range(3):
            lo_[a] = rot[a] * qx + rot[3 + a] * qy + rot[6 + a] * qz
            ld[a] = rot[a] * dx + rot[3 + a] * dy + rot[6 + a] * dz
        t0, t1 = 0.0, best
        axis = -1
        sign = 0.0
        ok = True
        for a in range(3):
            half = boxes[k, 12 + a]
            if abs(ld[a]) < 1e-15:
                if lo_[a] < -half or lo_[a] > half:
                    ok = False
                    break
                continue
            ta = (-half - lo_[a]) / ld[a]
            tb = (half - lo_[a]) / ld[a]
            s = -1.0
            if ta > tb:
                ta, tb = tb, ta
                s = 1.0
            if ta > t0:
                t0 = ta
                axis = a
                sign = s
            t1 = min(t1, tb)
            if t0 > t1:
                ok = False
                break
        if ok and axis >= 0 and t0 < best:
            best = t0
            hit = True
            for i in range(3):
                bn[i] = rot[3 * i + axis] * sign
    if not hit:
        return np.inf, 0.0, 0.0, 0.0
    return best, bn[0], bn[1], bn[2]


@numba.njit(cache=True, parallel=True)
def cast(h, x0, y0, cell, z0, ztop, boxes, origin, dirs, tmax, out_t, out_cos, out_kind):
    """Cast rays from ``origin`` along unit ``dirs`` (n, 3) against the heightfield and the boxes.

    ``ztop`` bounds the heightfield from above (pass ``z0 + heights.max()``: rays are only walked
    through cells below it). Writes the range to the first hit (``inf`` if none within ``tmax``),
    the cosine of the incidence angle (between the ray and the surface normal) and what was hit
    (``HIT_*``). Rays run in parallel threads.
    """
    ox, oy, oz = origin[0], origin[1], origin[2]
    for i in numba.prange(dirs.shape[0]):
        dx, dy, dz = dirs[i, 0], dirs[i, 1], dirs[i, 2]
        tb, bx, by, bz = _ray_boxes(boxes, ox, oy, oz, dx, dy, dz, tmax)
        th, hx, hy, hz = _ray_hfield(h, x0, y0, cell, z0, ztop, ox, oy, oz, dx, dy, dz, min(tb, tmax))
        if th < tb:
            nn = np.sqrt(hx * hx + hy * hy + hz * hz)
            out_t[i] = th
            out_cos[i] = abs(hx * dx + hy * dy + hz * dz) / nn
            out_kind[i] = HIT_SOIL
        elif tb < np.inf:
            out_t[i] = tb
            out_cos[i] = abs(bx * dx + by * dy + bz * dz)
            out_kind[i] = HIT_BOX
        else:
            out_t[i] = np.inf
            out_cos[i] = 0.0
            out_kind[i] = HIT_NONE


@numba.njit(cache=True)
def affected(origin, dirs, t_end, x_lo, x_hi, y_lo, y_hi, z_hi, out):
    """Which rays may see a change of the heightfield inside a window (for recasting only those).

    A ray's first hit depends only on the heightfield cells its path crosses before the hit, and
    a cell cannot stop a ray that passes above all of its samples. So a ray whose path up to its
    previous hit (``t_end``; its maximum range where it hit nothing) never passes over the
    rectangle ``[x_lo, x_hi] x [y_lo, y_hi]`` at or below ``z_hi`` (the highest sample there before
    or after the change) has the same hit as before, to the bit, provided the walk starts at the
    same place (the same ``ztop`` in :func:`cast`). Writes ``out[i]`` True for the others.
    """
    ox, oy, oz = origin[0], origin[1], origin[2]
    for i in range(dirs.shape[0]):
        dx, dy, dz = dirs[i, 0], dirs[i, 1], dirs[i, 2]
        t0, t1 = 0.0, t_end[i]
        hit = True
        for o, d, lo, hi in ((ox, dx, x_lo, x_hi), (oy, dy, y_lo, y_hi)):
            if abs(d) < 1e-15:
                if o < lo or o > hi:
                    hit = False
            else:
                ta = (lo - o) / d
                tb = (hi - o) / d
                if ta > tb:
                    ta, tb = tb, ta
                t0 = max(t0, ta)
                t1 = min(t1, tb)
        # over the rectangle for t in [t0, t1]: the ray's lowest point there is at an end
        out[i] = hit and t0 <= t1 and min(oz + t0 * dz, oz + t1 * dz) <= z_hi
