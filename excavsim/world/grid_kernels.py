"""Compiled loops over the soil grid and the bucket's surface samples (numba, cached on disk).

The inner loops of :func:`~excavsim.world.kernels.soil_step`: bilinear sampling of the heightfield,
cutting the cells the edge swept, summing the surcharge ahead of the edge, and the elasto-plastic
bearing and friction on the bucket's outer surface. Grid conventions are those of
:class:`~excavsim.world.terrain.SoilGrid` (``h[row, col]``, row along y, col along x); ``grid`` is
the :data:`~excavsim.world.soil_records.GRID` record and ``p`` the
:data:`~excavsim.world.soil_records.PARAMS` record.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, inline="always")
def bilinear(h, x0, y0, cell, x, y):
    nr, nc = h.shape
    u = (x - x0) / cell
    v = (y - y0) / cell
    if u < 0.0 or v < 0.0 or u > nc - 1 or v > nr - 1:
        return -np.inf
    c0 = min(int(u), nc - 2)
    r0 = min(int(v), nr - 2)
    fu = u - c0
    fv = v - r0
    return ((1 - fu) * (1 - fv) * h[r0, c0] + fu * (1 - fv) * h[r0, c0 + 1]
            + (1 - fu) * fv * h[r0 + 1, c0] + fu * fv * h[r0 + 1, c0 + 1])


@numba.njit(cache=True)
def cut_swept(h, grid, a0, b0, a1, b1, window):
    """Lower the cells swept by the cutting edge to the edge's height (``grid``: a GRID record).

    The edge moved from segment (a0, b0) to segment (a1, b1) (world points, 3 each). The quad between
    them is sampled at most half a cell apart; each sample lowers its nearest cell to the edge height
    there (never below the box floor). ``window`` (4,) int64 receives the changed rows/cols
    [r0, r1, c0, c1) (r0 > r1 when nothing changed).

    Returns:
        the removed volume in height units (multiply by cell^2 for m^3).
    """
    x0, y0, cell, z0 = grid.x0_m, grid.y0_m, grid.cell_m, grid.z0_m
    nr, nc = h.shape
    span = max(np.hypot(b1[0] - a1[0], b1[1] - a1[1]), np.hypot(b0[0] - a0[0], b0[1] - a0[1]))
    travel = max(np.hypot(a1[0] - a0[0], a1[1] - a0[1]), np.hypot(b1[0] - b0[0], b1[1] - b0[1]))
    nu = int(np.ceil(span / (0.5 * cell))) + 1
    nv = int(np.ceil(travel / (0.5 * cell))) + 1
    removed = 0.0
    window[0] = nr
    window[1] = -1
    window[2] = nc
    window[3] = -1
    for iv in range(nv):
        t = iv / (nv - 1) if nv > 1 else 1.0
        pax = a0[0] + t * (a1[0] - a0[0])
        pay = a0[1] + t * (a1[1] - a0[1])
        paz = a0[2] + t * (a1[2] - a0[2])
        pbx = b0[0] + t * (b1[0] - b0[0])
        pby = b0[1] + t * (b1[1] - b0[1])
        pbz = b0[2] + t * (b1[2] - b0[2])
        for iu in range(nu):
            s = iu / (nu - 1) if nu > 1 else 0.5
            x = pax + s * (pbx - pax)
            y = pay + s * (pby - pay)
            z = paz + s * (pbz - paz) - z0
            if z < 0.0:
                z = 0.0
            c = int(np.floor((x - x0) / cell + 0.5))
            r = int(np.floor((y - y0) / cell + 0.5))
            if r < 0 or r >= nr or c < 0 or c >= nc:
                continue
            if h[r, c] > z:
                removed += h[r, c] - z
                h[r, c] = z
                window[0] = min(window[0], r)
                window[1] = max(window[1], r + 1)
                window[2] = min(window[2], c)
                window[3] = max(window[3], c + 1)
    return removed


@numba.njit(cache=True)
def surcharge_volume(h, grid, centre, across, ahead, width, length, z_ref):
    """Volume of soil above ``z_ref`` on the rectangle ahead of the edge [m^3].

    The rectangle starts at ``centre`` (the edge centre), spans ``width`` along the unit vector
    ``across`` and ``length`` along the horizontal unit vector ``ahead``; sampled at the spacing of
    the cells of ``grid`` (a GRID record).
    """
    x0, y0, cell, z0 = grid.x0_m, grid.y0_m, grid.cell_m, grid.z0_m
    if length <= 0.0:
        return 0.0
    nu = max(1, int(np.ceil(width / cell)))
    nv = max(1, int(np.ceil(length / cell)))
    du = width / nu
    dv = length / nv
    vol = 0.0
    for iv in range(nv):
        t = (iv + 0.5) * dv
        for iu in range(nu):
            s = (iu + 0.5) * du - 0.5 * width
            x = centre[0] + s * across[0] + t * ahead[0]
            y = centre[1] + s * across[1] + t * ahead[1]
            z = bilinear(h, x0, y0, cell, x, y) + z0
            if z > z_ref:
                vol += (z - z_ref) * du * dv
    return vol


@numba.njit(cache=True)
def bearing(h, grid, pts, normals, vel, surface, sigma, dt, p, ref, across, out_force, out_torque):
    """Elasto-plastic bearing pressure and friction on the buried outer surface of the bucket.

    For each active sample of ``surface`` (SURFACE_SAMPLE records: area, active flag) at the world
    point ``pts[i]`` with outward normal ``normals[i]`` and velocity ``vel[i]``, buried ``d`` below
    the surface of the terrain ``h`` on ``grid``, the normal pressure ``sigma[i]`` (state, updated in
    place) moves by ``k_mob * (v . n) * dt`` as the surface pushes into or withdraws from the soil,
    bounded below by the at-rest pressure ``k_rest * d`` and above by the bearing capacity
    ``q_ult0 + q_ult_slope * d``. Friction ``mu * sigma * area`` opposes the tangential slip in the
    bucket's own plane (the slip along the unit vector ``across``, the bucket's width, is left out:
    trenching is planar, and friction across the soft wrist yaw and roll chattered), regularized
    below ``max(v_eps, mu N dt / m_ref)`` with ``N`` the total normal force: the friction's implied
    damping then stays below ``m_ref / dt``, which the explicit, once-per-control-step update needs
    to stay stable (``m_ref`` is a lower bound on the bucket's effective mass). The constants are
    the fields of the PARAMS record ``p``. Forces on the bucket and their moment about ``ref`` are
    written to ``out_force`` and ``out_torque`` (3,).

    Returns:
        the largest penetration [m].
    """
    x0, y0, cell, z0 = grid.x0_m, grid.y0_m, grid.cell_m, grid.z0_m
    k_rest, q_ult0, q_ult_slope, k_mob = p.k_rest_pa_per_m, p.q_ult0_pa, p.q_ult_slope_pa_per_m, p.k_mob_pa_per_m
    mu, v_eps, m_ref = p.mu, p.friction_velocity_m_s, p.friction_mass_kg
    fx = fy = fz = 0.0
    tx = ty = tz = 0.0
    pmax = 0.0
    n_total = 0.0
    for i in range(pts.shape[0]):
        if not surface[i].active:
            sigma[i] = 0.0
            continue
        s = bilinear(h, x0, y0, cell, pts[i, 0], pts[i, 1]) + z0
        d = s - pts[i, 2]
        if d <= 0.0:
            sigma[i] = 0.0
            continue
        pmax = max(pmax, d)
        vn = vel[i, 0] * normals[i, 0] + vel[i, 1] * normals[i, 1] + vel[i, 2] * normals[i, 2]
        sg = min(max(sigma[i] + k_mob * vn * dt, k_rest * d), q_ult0 + q_ult_slope * d)
        sigma[i] = sg
        n_total += sg * surface[i].area_m2
    v_reg = max(v_eps, mu * n_total * dt / m_ref)
    for i in range(pts.shape[0]):
        sg = sigma[i]
        if sg == 0.0:
            continue
        nx, ny, nz = normals[i, 0], normals[i, 1], normals[i, 2]
        vn = vel[i, 0] * nx + vel[i, 1] * ny + vel[i, 2] * nz
        a = surface[i].area_m2
        # pressure pushes the surface inward (-n); friction opposes tangential slip
        px = -sg * a * nx
        py = -sg * a * ny
        pz = -sg * a * nz
        vtx = vel[i, 0] - vn * nx
        vty = vel[i, 1] - vn * ny
        vtz = vel[i, 2] - vn * nz
        va = vtx * across[0] + vty * across[1] + vtz * across[2]
        vtx -= va * across[0]
        vty -= va * across[1]
        vtz -= va * across[2]
        vt = np.sqrt(vtx * vtx + vty * vty + vtz * vtz)
        if vt > 0.0:
            scale = mu * sg * a / max(vt, v_reg)
            px -= scale * vtx
            py -= scale * vty
            pz -= scale * vtz
        fx += px
        fy += py
        fz += pz
        rx = pts[i, 0] - ref[0]
        ry = pts[i, 1] - ref[1]
        rz = pts[i, 2] - ref[2]
        tx += ry * pz - rz * py
        ty += rz * px - rx * pz
        tz += rx * py - ry * px
    out_force[0] = fx
    out_force[1] = fy
    out_force[2] = fz
    out_torque[0] = tx
    out_torque[1] = ty
    out_torque[2] = tz
    return pmax


@numba.njit(cache=True)
def all_below(h, grid, x_lo, x_hi, y_lo, y_hi, z):
    """Whether every sample of ``h`` that bilinear sampling or the nearest-cell cutting of points in
    the world rectangle ``[x_lo, x_hi] x [y_lo, y_hi]`` can read lies strictly below the world height
    ``z`` (``grid``: a GRID record). A NaN height, bound or ``z`` answers False; a rectangle wholly
    outside the grid answers True (no sample is read there).
    """
    x0, y0, cell, z0 = grid.x0_m, grid.y0_m, grid.cell_m, grid.z0_m
    if not (np.isfinite(x_lo) and np.isfinite(x_hi) and np.isfinite(y_lo) and np.isfinite(y_hi)
            and np.isfinite(z)):
        return False
    nr, nc = h.shape
    # bilinear reads cells floor(u) and floor(u) + 1, cutting the nearest one: a cell's margin either side
    # (the cell coordinates are clamped before the conversion to integers: far points stay in range)
    c_lo = max(int(np.floor(min(max((x_lo - x0) / cell, -4.0), nc + 4.0))) - 1, 0)
    c_hi = min(int(np.floor(min(max((x_hi - x0) / cell, -4.0), nc + 4.0))) + 2, nc - 1)
    r_lo = max(int(np.floor(min(max((y_lo - y0) / cell, -4.0), nr + 4.0))) - 1, 0)
    r_hi = min(int(np.floor(min(max((y_hi - y0) / cell, -4.0), nr + 4.0))) + 2, nr - 1)
    top = z - z0
    for r in range(r_lo, r_hi + 1):
        for c in range(c_lo, c_hi + 1):
            if not (h[r, c] < top):
                return False
    return True
