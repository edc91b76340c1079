"""Compiled loops over grid cells and bucket samples for the soil model (numba, cached on disk).

These are the per-control-step inner loops of :mod:`excavsim.world.soil`: cutting the swept cells,
sampling the surface under bucket points, summing the surcharge ahead of the edge, and the
elasto-plastic bearing and friction of the bucket's outer surface. Grid conventions are those of
:class:`~excavsim.world.terrain.SoilGrid` (``h[row, col]``, row along y, col along x). The kernel's
parameters, state and outputs are the named records of :mod:`excavsim.world.soil_records`; inside
the compiled code a record (``grid``, ``p``, ``st``, ``o``) is a reference to its array's memory.
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
def surface_heights(h, grid, pts, out):
    """World surface height under each of ``pts`` (n, 3) into ``out`` (n,); -inf off the grid.

    ``grid`` is a :data:`~excavsim.world.soil_records.GRID` record (an element, not the array).
    """
    x0, y0, cell, z0 = grid.x0_m, grid.y0_m, grid.cell_m, grid.z0_m
    for i in range(pts.shape[0]):
        out[i] = _bilinear(h, x0, y0, cell, pts[i, 0], pts[i, 1]) + z0


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
            z = _bilinear(h, x0, y0, cell, x, y) + z0
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
        s = _bilinear(h, x0, y0, cell, pts[i, 0], pts[i, 1]) + z0
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


@numba.njit(cache=True, inline="always")
def _set3(v, x, y, z):
    v[0] = x
    v[1] = y
    v[2] = z


@numba.njit(cache=True, inline="always")
def _remember_edge(st, ends, cx, cy, cz):
    prev = st.prev_edge_ends_m
    for i in range(3):
        prev[0, i] = ends[0, i]
        prev[1, i] = ends[1, i]
    centre = st.prev_edge_centre_m
    centre[0] = cx
    centre[1] = cy
    centre[2] = cz


@numba.njit(cache=True)
def soil_step(heights, strength, grid, mj_arrays, bucket_vel6, bucket, edge, surface, table, rocks, params, dt_s,
              state, pressure, out):
    """One control step of the bucket-soil interaction (see :mod:`excavsim.world.soil`).

    Cuts the swept cells; updates the state (previous edge, elastic cutting force, shear travel,
    load) and the bearing pressures; writes the forces on the bucket, their moment about its centre
    of mass (cutting, bearing, rocks and the load's weight, with the load after this step's cut)
    and diagnostics to ``out``. The records are those of :mod:`excavsim.world.soil_records`, each
    single one as its ``(1,)`` array.

    Args:
        heights, strength, grid: the terrain: ``SoilGrid.heights`` (n_rows, n_cols) [m], cut in
            place; the soil-strength factor on the same cells [-]; its GRID record.
        mj_arrays, bucket_vel6: MuJoCo: the data arrays ``(xpos, xmat, xipos, site_xmat)``, read at
            the bucket's body and tip site; the bucket's (angular [rad/s], linear [m/s]) velocity at
            its origin, world frame, as ``mj_objectVelocity`` gives it (6,).
        bucket, edge, surface: the bucket: its BUCKET record, the (n_w, 3) cutting-edge samples [m]
            and the (n,) SURFACE_SAMPLE records of its outer surface, body frame.
        table: the wedge table, (m,) WEDGE_ROW records on the rake grid of ``params``.
        rocks: (n_rocks, 4) buried rocks: centre x, y, z and radius [m].
        params, dt_s: the PARAMS record; the length of the control step [s].
        state, pressure: the STATE record and the (n,) bearing pressures of the surface samples
            [Pa], both updated in place.
        out: the OUT record, every field written.
    """
    h = heights
    g = grid[0]
    x0, y0, cell, z0 = g.x0_m, g.y0_m, g.cell_m, g.z0_m
    xpos, xmat, xipos, site_xmat = mj_arrays
    bk = bucket[0]
    p = params[0]
    st = state[0]
    o = out[0]
    body = bk.body_id
    rot = xmat[body].reshape(3, 3)
    org = xpos[body]
    com = xipos[body]
    omega = bucket_vel6[0:3]
    v_org = bucket_vel6[3:6]
    tip = site_xmat[bk.tip_site_id].reshape(3, 3)
    x_t = np.array([tip[0, 0], tip[1, 0], tip[2, 0]])
    z_t = np.array([tip[0, 2], tip[1, 2], tip[2, 2]])
    nw = edge.shape[0]
    ends_body = bk.edge_ends_m
    centroid = bk.load_centroid_m
    pts_body = surface.point_m
    normals_body = surface.normal
    t_rake0 = p.table_rake0_rad
    t_step = p.table_rake_step_rad
    sd = p.sin_delta
    cd = p.cos_delta
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
            ew[k, i] = (org[i] + rot[i, 0] * edge[k, 0] + rot[i, 1] * edge[k, 1]
                        + rot[i, 2] * edge[k, 2])
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
            ends[e, i] = (org[i] + rot[i, 0] * ends_body[e, 0] + rot[i, 1] * ends_body[e, 1]
                          + rot[i, 2] * ends_body[e, 2])
    if not st.has_prev:
        _remember_edge(st, ends, cx, cy, cz)
        st.has_prev = True
    prev_c = st.prev_edge_centre_m
    travel = -((cx - prev_c[0]) * ux + (cy - prev_c[1]) * uy + (cz - prev_c[2]) * uz)
    speed = max(travel, 0.0) / dt_s

    # wedge failure force (eq. 8 + adhesion + surcharge) with the truth terms
    f_fail = 0.0
    if depth > 0.0:
        rk = max(rake, p.rake_min_rad)
        ng = _interp_uniform(t_rake0, t_step, table.n_gamma, rk)
        nc = _interp_uniform(t_rake0, t_step, table.n_c, rk)
        nadh = _interp_uniform(t_rake0, t_step, table.n_a, rk)
        den = _interp_uniform(t_rake0, t_step, table.denominator, rk)
        beta = _interp_uniform(t_rake0, t_step, table.beta_rad, rk)
        dw = bk.width_m / nw
        f_static = (p.gamma_g_n_m3 * d2sum * ng + p.cohesion_pa * dsum * nc + p.adhesion_pa * dsum * nadh) * dw
        wedge_len = depth * (1.0 / np.tan(rk) + 1.0 / np.tan(beta))
        ex = ends[1, 0] - ends[0, 0]
        ey = ends[1, 1] - ends[0, 1]
        ez = ends[1, 2] - ends[0, 2]
        en = max(np.sqrt(ex * ex + ey * ey + ez * ez), 1e-9)
        centre = np.array([cx, cy, cz])
        across = np.array([ex / en, ey / en, ez / en])
        ahead = np.array([ax, ay, 0.0])
        v_ahead = surcharge_volume(h, g, centre, across, ahead, bk.width_m, wedge_len, cz + depth)
        surcharge = v_ahead + p.load_surcharge_fraction * st.load_m3
        f_static += p.gamma_g_n_m3 * surcharge / den
        c = int(np.floor((cx - x0) / cell + 0.5))
        r = int(np.floor((cy - y0) / cell + 0.5))
        hetero = 1.0
        if 0 <= r < strength.shape[0] and 0 <= c < strength.shape[1]:
            hetero = strength[r, c]
        if travel > 0.0:
            st.shear_travel_m += travel
        period = max(0.01, depth / np.tan(beta))
        phase = (st.shear_travel_m / period) % 1.0
        saw = 1.0 - p.sawtooth_amplitude * (1.0 - phase)
        f_fail = f_static * (1.0 + p.speed_coefficient_s_per_m * speed) * hetero * saw
    fc = min(max(st.cut_force_n + p.cut_stiffness_n_per_m * travel, 0.0), f_fail)
    st.cut_force_n = fc
    fcx, fcy, fcz = fc * ux, fc * uy, fc * uz

    # cut the swept cells
    prev_ends = st.prev_edge_ends_m
    removed = cut_swept(h, g, prev_ends[0], prev_ends[1], ends[0], ends[1], o.window)
    cut = removed * cell * cell
    take = min(cut, max(p.capacity_m3 - st.load_m3, 0.0))
    st.load_m3 += take
    _remember_edge(st, ends, cx, cy, cz)

    # bearing and friction on the outer surface
    n = surface.shape[0]
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
    pmax = bearing(h, g, pts, nrm, vel, surface, pressure, dt_s, p, com, across_b, fb, tb)

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
                s = p.rock_stiffness_n_per_m * pen / max(dist, 1e-9)
                fx, fy, fz = s * ox, s * oy, s * oz
                frx += fx
                fry += fy
                frz += fz
                lx, ly, lz = px - com[0], py - com[1], pz - com[2]
                trx += ly * fz - lz * fy
                try_ += lz * fx - lx * fz
                trz += lx * fy - ly * fx

    # the load's weight at the centroid of the bucket interior
    wz = -p.gamma_g_n_m3 * st.load_m3
    gx = org[0] + rot[0, 0] * centroid[0] + rot[0, 1] * centroid[1] + rot[0, 2] * centroid[2] - com[0]
    gy = org[1] + rot[1, 0] * centroid[0] + rot[1, 1] * centroid[1] + rot[1, 2] * centroid[2] - com[1]
    trx += gy * wz
    try_ -= gx * wz
    lx, ly, lz = cx - com[0], cy - com[1], cz - com[2]
    o.load_weight_z_n = wz
    o.depth_m = depth
    o.rake_rad = rake
    o.cutting_speed_m_s = speed
    o.wedge_failure_force_n = f_fail
    _set3(o.cutting_force_n, fcx, fcy, fcz)
    _set3(o.bearing_force_n, fb[0], fb[1], fb[2])
    _set3(o.rock_force_n, frx, fry, frz)
    _set3(o.force_n, fcx + fb[0] + frx, fcy + fb[1] + fry, fcz + fb[2] + frz + wz)
    _set3(o.torque_nm, ly * fcz - lz * fcy + tb[0] + trx, lz * fcx - lx * fcz + tb[1] + try_,
          lx * fcy - ly * fcx + tb[2] + trz)
    o.cut_volume_m3 = cut
    o.taken_volume_m3 = take
    o.max_penetration_m = pmax
    _set3(o.ahead, ax, ay, 0.0)
    _set3(o.edge_centre_m, cx, cy, cz)
