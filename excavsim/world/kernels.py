"""Compiled loops over grid cells and bucket samples for the soil model (numba, cached on disk).

These are the per-control-step inner loops of :mod:`excavsim.world.soil`: cutting the swept cells,
sampling the surface under bucket points, summing the surcharge ahead of the edge, and the
elasto-plastic bearing and friction of the bucket's outer surface. Grid conventions are those of
:class:`~excavsim.world.terrain.SoilGrid` (``h[row, col]``, row along y, col along x).
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, inline="always")
def _bilinear(h, x0, y0, cell, x, y):
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
def surface_heights(h, x0, y0, cell, z0, pts, out):
    """World surface height under each of ``pts`` (n, 3) into ``out`` (n,); -inf off the grid."""
    for i in range(pts.shape[0]):
        out[i] = _bilinear(h, x0, y0, cell, pts[i, 0], pts[i, 1]) + z0


@numba.njit(cache=True)
def cut_swept(h, x0, y0, cell, z0, a0, b0, a1, b1, window):
    """Lower the cells swept by the cutting edge to the edge's height.

    The edge moved from segment (a0, b0) to segment (a1, b1) (world points, 3 each). The quad between
    them is sampled at most half a cell apart; each sample lowers its nearest cell to the edge height
    there (never below the box floor). ``window`` (4,) int64 receives the changed rows/cols
    [r0, r1, c0, c1) (r0 > r1 when nothing changed).

    Returns:
        the removed volume in height units (multiply by cell^2 for m^3).
    """
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
def surcharge_volume(h, x0, y0, cell, z0, centre, across, ahead, width, length, z_ref):
    """Volume of soil above ``z_ref`` on the rectangle ahead of the edge [m^3].

    The rectangle starts at ``centre`` (the edge centre), spans ``width`` along the unit vector
    ``across`` and ``length`` along the horizontal unit vector ``ahead``; sampled at cell spacing.
    """
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
            z = _bilinear(h, x0, y0, cell, x, y) + z0
            if z > z_ref:
                vol += (z - z_ref) * du * dv
    return vol


@numba.njit(cache=True)
def bearing(h, x0, y0, cell, z0, pts, normals, areas, vel, active, sigma, dt,
            k_rest, q_ult0, q_ult_slope, k_mob, mu, v_eps, m_ref, ref, across, out_force, out_torque):
    """Elasto-plastic bearing pressure and friction on the buried outer surface of the bucket.

    For each active sample (point ``pts[i]``, outward normal ``normals[i]``, area ``areas[i]``,
    velocity ``vel[i]``) buried ``p`` below the surface, the normal pressure ``sigma[i]`` (state,
    updated in place) moves by ``k_mob * (v . n) * dt`` as the surface pushes into or withdraws from
    the soil, bounded below by the at-rest pressure ``k_rest * p`` and above by the bearing capacity
    ``q_ult0 + q_ult_slope * p``. Friction ``mu * sigma * area`` opposes the tangential slip in the
    bucket's own plane (the slip along the unit vector ``across``, the bucket's width, is left out:
    trenching is planar, and friction across the soft wrist yaw and roll chattered), regularized
    below ``max(v_eps, mu N dt / m_ref)`` with ``N`` the total normal force: the friction's implied
    damping then stays below ``m_ref / dt``, which the explicit, once-per-control-step update needs
    to stay stable (``m_ref`` is a lower bound on the bucket's effective mass). Forces on the bucket and their moment about ``ref`` are written to
    ``out_force`` and ``out_torque`` (3,).

    Returns:
        the largest penetration [m].
    """
    fx = fy = fz = 0.0
    tx = ty = tz = 0.0
    pmax = 0.0
    n_total = 0.0
    for i in range(pts.shape[0]):
        if active[i] == 0.0:
            sigma[i] = 0.0
            continue
        s = _bilinear(h, x0, y0, cell, pts[i, 0], pts[i, 1]) + z0
        p = s - pts[i, 2]
        if p <= 0.0:
            sigma[i] = 0.0
            continue
        pmax = max(pmax, p)
        vn = vel[i, 0] * normals[i, 0] + vel[i, 1] * normals[i, 1] + vel[i, 2] * normals[i, 2]
        sg = min(max(sigma[i] + k_mob * vn * dt, k_rest * p), q_ult0 + q_ult_slope * p)
        sigma[i] = sg
        n_total += sg * areas[i]
    v_reg = max(v_eps, mu * n_total * dt / m_ref)
    for i in range(pts.shape[0]):
        sg = sigma[i]
        if sg == 0.0:
            continue
        nx, ny, nz = normals[i, 0], normals[i, 1], normals[i, 2]
        vn = vel[i, 0] * nx + vel[i, 1] * ny + vel[i, 2] * nz
        a = areas[i]
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


@numba.njit(cache=True, inline="always")
def _interp_uniform(grid0, step, values, x):
    n = values.shape[0]
    u = (x - grid0) / step
    if u <= 0.0:
        return values[0]
    if u >= n - 1:
        return values[n - 1]
    i = int(u)
    t = u - i
    return values[i] + t * (values[i + 1] - values[i])


# The depth of the edge is taken against the surface this many cells ahead of it: beyond the half
# cell around the edge that cutting lowers, so bilinear interpolation never sees a cut sample.
PROBE_CELLS = 2.0

# Indices into the ``state`` and ``params`` vectors of :func:`soil_step` (kept in one place).
S_PREV_A, S_PREV_B, S_PREV_C, S_HAS_PREV, S_CUT_FORCE, S_SHEAR_TRAVEL, S_LOAD, S_LEN = 0, 3, 6, 9, 10, 11, 12, 13
(P_GAMMA_G, P_COHESION, P_ADHESION, P_SIN_DELTA, P_COS_DELTA, P_WIDTH, P_DT, P_K_CUT, P_SPEED, P_SAW,
 P_LOAD_SURCHARGE, P_CAPACITY, P_K_REST, P_Q0, P_Q_SLOPE, P_K_MOB, P_MU, P_V_EPS, P_K_ROCK, P_RAKE_MIN,
 P_M_REF, P_LEN) = range(22)
# Indices into the ``out`` vector.
(O_DEPTH, O_RAKE, O_SPEED, O_FAIL, O_FCUT, O_FBEAR, O_FROCK, O_FORCE, O_TORQUE, O_CUT, O_TAKE, O_PMAX,
 O_AHEAD, O_CENTRE, O_WEIGHT, O_LEN) = (0, 1, 2, 3, 4, 7, 10, 13, 16, 19, 20, 21, 22, 25, 28, 29)


@numba.njit(cache=True, inline="always")
def _remember_edge(state, ends, cx, cy, cz):
    for i in range(3):
        state[S_PREV_A + i] = ends[0, i]
        state[S_PREV_B + i] = ends[1, i]
    state[S_PREV_C] = cx
    state[S_PREV_C + 1] = cy
    state[S_PREV_C + 2] = cz


@numba.njit(cache=True)
def soil_step(h, x0, y0, cell, z0, xpos, xmat, xipos, site_xmat, body, site, vel6, edge_pack, surf_pack, sigma,
              t_rake0, t_step, table, strength, rocks, state, params, window, out):
    """One control step of the bucket-soil interaction (see :mod:`excavsim.world.soil`).

    Arguments are packed to keep the call cheap:

    * ``xpos``, ``xmat``, ``xipos``, ``site_xmat``: MuJoCo's data arrays, read at the bucket
      ``body`` and the tip ``site``; ``vel6`` the bucket's (angular, linear) velocity at its origin;
    * ``edge_pack`` (n_w + 3, 3): the edge samples, the two ends of the edge and the load's centroid
      (body frame);
    * ``surf_pack`` (n, 8): outer-surface samples: point (3), outward normal (3), area, active flag;
    * ``table`` (5, m): beta, N_gamma, N_c, N_a, denominator on the uniform rake grid
      ``t_rake0 + i t_step``.

    Cuts the swept cells; updates ``state`` (previous edge, elastic cutting force, shear travel,
    load) and the bearing pressures ``sigma``; writes forces on the bucket, their moment about the
    centre of mass (cutting, bearing, rocks and the load's weight, with the load after this step's
    cut) and diagnostics to ``out``.
    """
    rot = xmat[body].reshape(3, 3)
    org = xpos[body]
    com = xipos[body]
    omega = vel6[0:3]
    v_org = vel6[3:6]
    tip = site_xmat[site].reshape(3, 3)
    x_t = np.array([tip[0, 0], tip[1, 0], tip[2, 0]])
    z_t = np.array([tip[0, 2], tip[1, 2], tip[2, 2]])
    nw = edge_pack.shape[0] - 3
    edge_body = edge_pack[:nw]
    ends_body = edge_pack[nw:nw + 2]
    centroid = edge_pack[nw + 2]
    pts_body = surf_pack[:, 0:3]
    normals_body = surf_pack[:, 3:6]
    areas = surf_pack[:, 6]
    active = surf_pack[:, 7]
    t_beta = table[0]
    t_ng = table[1]
    t_nc = table[2]
    t_na = table[3]
    t_den = table[4]
    sd = params[P_SIN_DELTA]
    cd = params[P_COS_DELTA]
    dt = params[P_DT]
    # force direction (eq. 8) and the horizontal direction the blade pushes the soil
    ux = -sd * x_t[0] - cd * z_t[0]
    uy = -sd * x_t[1] - cd * z_t[1]
    uz = -sd * x_t[2] - cd * z_t[2]
    ax, ay = -ux, -uy
    na = np.hypot(ax, ay)
    if na < 1e-9:
        ax, ay = x_t[0], x_t[1]
        na = max(np.hypot(ax, ay), 1e-9)
    ax /= na
    ay /= na
    rake = np.arctan2(-x_t[2], z_t[2])

    # edge samples in the world, and the depth below the surface just ahead of each
    cx = cy = cz = 0.0
    dsum = 0.0
    d2sum = 0.0
    ew = np.empty((nw, 3))
    for k in range(nw):
        for i in range(3):
            ew[k, i] = (org[i] + rot[i, 0] * edge_body[k, 0] + rot[i, 1] * edge_body[k, 1]
                        + rot[i, 2] * edge_body[k, 2])
        px, py, pz = ew[k, 0], ew[k, 1], ew[k, 2]
        cx += px
        cy += py
        cz += pz
        s = _bilinear(h, x0, y0, cell, px + ax * PROBE_CELLS * cell, py + ay * PROBE_CELLS * cell) + z0
        d = s - pz
        if d > 0.0 and np.isfinite(d):
            dsum += d
            d2sum += d * d
    cx /= nw
    cy /= nw
    cz /= nw
    depth = dsum / nw
    ends = np.empty((2, 3))
    for e in range(2):
        for i in range(3):
            ends[e, i] = org[i] + rot[i, 0] * ends_body[e, 0] + rot[i, 1] * ends_body[e, 1] + rot[i, 2] * ends_body[e, 2]
    if state[S_HAS_PREV] == 0.0:
        _remember_edge(state, ends, cx, cy, cz)
        state[S_HAS_PREV] = 1.0
    travel = -((cx - state[S_PREV_C]) * ux + (cy - state[S_PREV_C + 1]) * uy + (cz - state[S_PREV_C + 2]) * uz)
    speed = max(travel, 0.0) / dt

    # wedge failure force (eq. 8 + adhesion + surcharge) with the truth terms
    f_fail = 0.0
    if depth > 0.0:
        rk = max(rake, params[P_RAKE_MIN])
        ng = _interp_uniform(t_rake0, t_step, t_ng, rk)
        nc = _interp_uniform(t_rake0, t_step, t_nc, rk)
        nadh = _interp_uniform(t_rake0, t_step, t_na, rk)
        den = _interp_uniform(t_rake0, t_step, t_den, rk)
        beta = _interp_uniform(t_rake0, t_step, t_beta, rk)
        dw = params[P_WIDTH] / nw
        f_static = (params[P_GAMMA_G] * d2sum * ng + params[P_COHESION] * dsum * nc
                    + params[P_ADHESION] * dsum * nadh) * dw
        wedge_len = depth * (1.0 / np.tan(rk) + 1.0 / np.tan(beta))
        ex = ends[1, 0] - ends[0, 0]
        ey = ends[1, 1] - ends[0, 1]
        ez = ends[1, 2] - ends[0, 2]
        en = max(np.sqrt(ex * ex + ey * ey + ez * ez), 1e-9)
        centre = np.array([cx, cy, cz])
        across = np.array([ex / en, ey / en, ez / en])
        ahead = np.array([ax, ay, 0.0])
        v_ahead = surcharge_volume(h, x0, y0, cell, z0, centre, across, ahead, params[P_WIDTH], wedge_len,
                                   cz + depth)
        surcharge = v_ahead + params[P_LOAD_SURCHARGE] * state[S_LOAD]
        f_static += params[P_GAMMA_G] * surcharge / den
        c = int(np.floor((cx - x0) / cell + 0.5))
        r = int(np.floor((cy - y0) / cell + 0.5))
        hetero = 1.0
        if 0 <= r < strength.shape[0] and 0 <= c < strength.shape[1]:
            hetero = strength[r, c]
        if travel > 0.0:
            state[S_SHEAR_TRAVEL] += travel
        period = max(0.01, depth / np.tan(beta))
        phase = (state[S_SHEAR_TRAVEL] / period) % 1.0
        saw = 1.0 - params[P_SAW] * (1.0 - phase)
        f_fail = f_static * (1.0 + params[P_SPEED] * speed) * hetero * saw
    fc = min(max(state[S_CUT_FORCE] + params[P_K_CUT] * travel, 0.0), f_fail)
    state[S_CUT_FORCE] = fc
    fcx, fcy, fcz = fc * ux, fc * uy, fc * uz

    # cut the swept cells
    removed = cut_swept(h, x0, y0, cell, z0, state[S_PREV_A:S_PREV_A + 3], state[S_PREV_B:S_PREV_B + 3],
                        ends[0], ends[1], window)
    cut = removed * cell * cell
    take = min(cut, max(params[P_CAPACITY] - state[S_LOAD], 0.0))
    state[S_LOAD] += take
    _remember_edge(state, ends, cx, cy, cz)

    # bearing and friction on the outer surface
    n = pts_body.shape[0]
    pts = np.empty((n, 3))
    nrm = np.empty((n, 3))
    vel = np.empty((n, 3))
    for k in range(n):
        for i in range(3):
            pts[k, i] = org[i] + rot[i, 0] * pts_body[k, 0] + rot[i, 1] * pts_body[k, 1] + rot[i, 2] * pts_body[k, 2]
            nrm[k, i] = rot[i, 0] * normals_body[k, 0] + rot[i, 1] * normals_body[k, 1] + rot[i, 2] * normals_body[k, 2]
        rx = pts[k, 0] - org[0]
        ry = pts[k, 1] - org[1]
        rz = pts[k, 2] - org[2]
        vel[k, 0] = v_org[0] + omega[1] * rz - omega[2] * ry
        vel[k, 1] = v_org[1] + omega[2] * rx - omega[0] * rz
        vel[k, 2] = v_org[2] + omega[0] * ry - omega[1] * rx
    fb = np.zeros(3)
    tb = np.zeros(3)
    across_b = np.array([rot[0, 1], rot[1, 1], rot[2, 1]])
    pmax = bearing(h, x0, y0, cell, z0, pts, nrm, areas, vel, active, sigma, dt, params[P_K_REST], params[P_Q0],
                   params[P_Q_SLOPE], params[P_K_MOB], params[P_MU], params[P_V_EPS], params[P_M_REF], com, across_b, fb, tb)

    # rocks push the edge samples out
    frx = fry = frz = 0.0
    trx = try_ = trz = 0.0
    for j in range(rocks.shape[0]):
        for k in range(nw):
            px, py, pz = ew[k, 0], ew[k, 1], ew[k, 2]
            ox, oy, oz = px - rocks[j, 0], py - rocks[j, 1], pz - rocks[j, 2]
            dist = np.sqrt(ox * ox + oy * oy + oz * oz)
            pen = rocks[j, 3] - dist
            if pen > 0.0:
                s = params[P_K_ROCK] * pen / max(dist, 1e-9)
                fx, fy, fz = s * ox, s * oy, s * oz
                frx += fx
                fry += fy
                frz += fz
                lx, ly, lz = px - com[0], py - com[1], pz - com[2]
                trx += ly * fz - lz * fy
                try_ += lz * fx - lx * fz
                trz += lx * fy - ly * fx

    # the load's weight at the centroid of the bucket interior
    wz = -params[P_GAMMA_G] * state[S_LOAD]
    gx = org[0] + rot[0, 0] * centroid[0] + rot[0, 1] * centroid[1] + rot[0, 2] * centroid[2] - com[0]
    gy = org[1] + rot[1, 0] * centroid[0] + rot[1, 1] * centroid[1] + rot[1, 2] * centroid[2] - com[1]
    trx += gy * wz
    try_ -= gx * wz
    lx, ly, lz = cx - com[0], cy - com[1], cz - com[2]
    out[O_WEIGHT] = wz
    out[O_DEPTH] = depth
    out[O_RAKE] = rake
    out[O_SPEED] = speed
    out[O_FAIL] = f_fail
    out[O_FCUT] = fcx
    out[O_FCUT + 1] = fcy
    out[O_FCUT + 2] = fcz
    out[O_FBEAR:O_FBEAR + 3] = fb
    out[O_FROCK] = frx
    out[O_FROCK + 1] = fry
    out[O_FROCK + 2] = frz
    out[O_FORCE] = fcx + fb[0] + frx
    out[O_FORCE + 1] = fcy + fb[1] + fry
    out[O_FORCE + 2] = fcz + fb[2] + frz + wz
    out[O_TORQUE] = ly * fcz - lz * fcy + tb[0] + trx
    out[O_TORQUE + 1] = lz * fcx - lx * fcz + tb[1] + try_
    out[O_TORQUE + 2] = lx * fcy - ly * fcx + tb[2] + trz
    out[O_CUT] = cut
    out[O_TAKE] = take
    out[O_PMAX] = pmax
    out[O_AHEAD] = ax
    out[O_AHEAD + 1] = ay
    out[O_AHEAD + 2] = 0.0
    out[O_CENTRE] = cx
    out[O_CENTRE + 1] = cy
    out[O_CENTRE + 2] = cz
