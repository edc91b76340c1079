"""The compiled control step of the bucket-soil interaction (numba, cached on disk).

:func:`soil_step` is the per-control-step kernel of :mod:`excavsim.world.soil`: the edge's depth and
the wedge's failure force (static, rate effect, inertia), the cutting force through the wedge's
failure cycle (:func:`failure_cycle`), cutting the swept cells, bearing and friction on the outer
surface, rocks, and the load's weight, summed into the wrench on the bucket. Its loops over grid
cells and surface samples are in :mod:`excavsim.world.grid_kernels`. While the bucket is clear of
the terrain (swinging, dumping, returning: most of an episode) it skips cutting and bearing
(:func:`clear_of_terrain`, a test of the terrain under the bucket's world bounding box, read every
step, so that no bound has to be maintained where the grid changes) and writes what they would:
the results are the same to the bit.
Grid conventions are those of :class:`~excavsim.world.terrain.SoilGrid` (``h[row, col]``, row along
y, col along x). The kernel's parameters, state and outputs are the named records of
:mod:`excavsim.world.soil_records`; inside the compiled code a record (``grid``, ``p``, ``st``,
``o``) is a reference to its array's memory.
"""

from __future__ import annotations

import numba
import numpy as np

from excavsim.world.grid_kernels import all_below, bearing, bilinear, cut_swept, surcharge_volume


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
def edge_depths(h, x0, y0, cell, z0, org, rot, edge, ax, ay, ew):
    """The cutting edge's samples ``edge`` (n_w, 3, body frame) in the world, written to ``ew``, their
    centre, and the sum and the sum of squares of their positive depths below the surface probed
    ``PROBE_CELLS`` cells ahead along the unit horizontal ``(ax, ay)``: (cx, cy, cz, dsum, d2sum)."""
    nw = edge.shape[0]
    cx = cy = cz = 0.0
    dsum = 0.0
    d2sum = 0.0
    for k in range(nw):
        for i in range(3):
            ew[k, i] = (org[i] + rot[i, 0] * edge[k, 0] + rot[i, 1] * edge[k, 1]
                        + rot[i, 2] * edge[k, 2])
        px, py, pz = ew[k, 0], ew[k, 1], ew[k, 2]
        cx += px
        cy += py
        cz += pz
        s = bilinear(h, x0, y0, cell, px + ax * PROBE_CELLS * cell, py + ay * PROBE_CELLS * cell) + z0
        d = s - pz
        if d > 0.0 and np.isfinite(d):
            dsum += d
            d2sum += d * d
    return cx / nw, cy / nw, cz / nw, dsum, d2sum


@numba.njit(cache=True, inline="always")
def edge_ends(org, rot, ends_body):
    """The cutting edge's two end points ``ends_body`` (2, 3, body frame) in the world (2, 3)."""
    ends = np.empty((2, 3))
    for e in range(2):
        for i in range(3):
            ends[e, i] = (org[i] + rot[i, 0] * ends_body[e, 0] + rot[i, 1] * ends_body[e, 1]
                          + rot[i, 2] * ends_body[e, 2])
    return ends


@numba.njit(cache=True, inline="always")
def remember_edge(st, ends, cx, cy, cz):
    prev = st.prev_edge_ends_m
    for i in range(3):
        prev[0, i] = ends[0, i]
        prev[1, i] = ends[1, i]
    centre = st.prev_edge_centre_m
    centre[0] = cx
    centre[1] = cy
    centre[2] = cz


# How far above the highest terrain sample it could touch the bucket must be to skip the soil's
# contact loops (:func:`clear_of_terrain`): far above the rounding of the interpolations it bounds.
CLEARANCE_MARGIN_M = 1e-6


@numba.njit(cache=True, inline="always")
def clear_of_terrain(h, grid, org, rot, box_body, prev_ends):
    """Whether the bucket is clear of the terrain: every point the step's contact loops read (the
    outer surface samples, the edge samples and their probes ``PROBE_CELLS`` cells ahead, the edge's
    ends now and at the last step) lies more than ``CLEARANCE_MARGIN_M`` above every terrain sample
    that their bilinear sampling or the cutting of the swept quad can read.

    ``box_body`` (2, 3) bounds all the bucket's samples in the body frame (low and high corners); its
    world bounding box ``org + rot box`` (centre plus the absolute rotation times the half extents)
    bounds their world positions, and the last step's edge ends widen it. A valid upper bound only:
    the answer False just means the full contact computation runs.

    When True, the full step would find no depth below the surface (no wedge), cut nothing, and set
    every bearing pressure to zero with no bearing force or moment: :func:`soil_step` then skips
    those loops and writes exactly what they would.
    """
    x_lo = y_lo = z_lo = np.inf
    x_hi = y_hi = -np.inf
    for i in range(3):
        c = org[i]
        r = 0.0
        for j in range(3):
            c += rot[i, j] * 0.5 * (box_body[0, j] + box_body[1, j])
            r += abs(rot[i, j]) * 0.5 * (box_body[1, j] - box_body[0, j])
        if i == 0:
            x_lo, x_hi = c - r, c + r
        elif i == 1:
            y_lo, y_hi = c - r, c + r
        else:
            z_lo = c - r
    for e in range(2):
        x_lo = min(x_lo, prev_ends[e, 0])
        x_hi = max(x_hi, prev_ends[e, 0])
        y_lo = min(y_lo, prev_ends[e, 1])
        y_hi = max(y_hi, prev_ends[e, 1])
        z_lo = min(z_lo, prev_ends[e, 2])
    if not (np.isfinite(prev_ends[0, 0] + prev_ends[0, 1] + prev_ends[0, 2] + prev_ends[1, 0] + prev_ends[1, 1]
                        + prev_ends[1, 2])):
        return False
    reach = PROBE_CELLS * grid.cell_m  # the depth probes ahead of the edge samples
    return all_below(h, grid, x_lo - reach, x_hi + reach, y_lo - reach, y_hi + reach, z_lo - CLEARANCE_MARGIN_M)


@numba.njit(cache=True, inline="always")
def load_surcharge_volume(load_m3, capacity_m3):
    """The part of the bucket's load that bears on the failure wedge as surcharge [m^3].

    Singh 1995 §5.1.2.1 eq. 7 and Fig. 57: the soil displaced by the tool is the surcharge ``Q`` on
    the wedge, entering eq. 5 as its weight over the denominator ``D`` (``q d N_q w = Q w / D``).
    §5.1.3: a bucket first takes the cut soil in, and "after a certain amount of soil is scooped,
    the soil becomes captive and additional travel results in a new cutting surface -- the soil at
    the surface of the bucket acts as the cutting surface": the load then rides on the soil
    entering the bucket. The share of the load that bears is its fill ``V / C`` of the heaped
    capacity ``C`` (assumed: linear between an empty bucket, where only the wedge acts, as in the
    short drags of Fig. 59, and a full one, where all the displaced soil does, as in Fig. 57), so
    ``V_s = V min(V / C, 1)``; beyond ``C`` the cut soil stays ahead of the edge and counts in the
    soil heaped on the wedge instead.
    """
    if load_m3 <= 0.0 or capacity_m3 <= 0.0:
        return 0.0
    return load_m3 * min(load_m3 / capacity_m3, 1.0)


@numba.njit(cache=True, inline="always")
def failure_cycle(st, p, travel, advance, f_nom, f_fail, spacing):
    """The cutting force on the blade through the wedge's failure cycle (Fig. 53-54); updates ``st``.

    First loading: the force builds elastically with the edge's ``travel`` into the soil
    (``cut_stiffness_n_per_m``) up to the failure force ``f_fail``, and relaxes when the edge backs
    off. When it reaches ``f_fail`` the wedge fails along its critical plane and the force drops by
    the brittleness index ``I_B`` (the failed wedge slides at its post-peak strength). From then on
    the blade pushes the failed wedge, of length ``spacing = d cot beta*`` ahead of the edge, off
    the intact soil while the next wedge takes up load: the share ``m`` of the nominal (strength 1)
    failure force ``f_nom`` it carries grows by ``I_B`` per ``spacing`` of horizontal ``advance``,
    and the next failure comes when ``m f_nom`` reaches ``f_fail`` (the local strength factor times
    the static part, plus the inertial part), after about
    ``hetero * d cot beta*`` of advance: the spacing follows the geometry and the local strength.
    With ``I_B = 0`` the force stays at the failure force (the static picture). Out of the soil
    (``f_fail = 0``) the cycle restarts.

    Returns:
        (the cutting force [N], whether the wedge failed this step).
    """
    ib = p.brittleness_index
    if f_fail <= 0.0:
        st.failed = False
        st.mobilised = 0.0
        st.cut_force_n = 0.0
        return 0.0, False
    if not st.failed or ib <= 0.0:
        fc = min(max(st.cut_force_n + p.cut_stiffness_n_per_m * travel, 0.0), f_fail)
        st.cut_force_n = fc
        if ib > 0.0 and fc >= f_fail:
            st.failed = True
            st.mobilised = (1.0 - ib) * f_fail / f_nom
            return fc, True
        return fc, False
    m = st.mobilised
    if travel < 0.0:
        m += p.cut_stiffness_n_per_m * travel / f_nom  # elastic unloading as the edge backs off
    elif advance > 0.0:
        m += ib * advance / spacing
    m = max(m, 0.0)
    failed = False
    if m * f_nom >= f_fail:
        fc = f_fail
        m = (1.0 - ib) * f_fail / f_nom
        failed = True
    else:
        fc = m * f_nom
    st.mobilised = m
    st.cut_force_n = fc
    return fc, failed


@numba.njit(cache=True)
def _bearing_step(h, g, org, rot, com, omega, v_org, surface, pressure, dt_s, p, fb, tb):
    """The outer surface's samples in the world (points, normals, velocities from the body's twist)
    and their bearing and friction (:func:`~excavsim.world.grid_kernels.bearing`), summed into
    ``fb`` and ``tb`` (3,); returns the largest penetration [m]."""
    pts_body = surface.point_m
    normals_body = surface.normal
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
    across_b = np.array([rot[0, 1], rot[1, 1], rot[2, 1]])
    return bearing(h, g, pts, nrm, vel, surface, pressure, dt_s, p, com, across_b, fb, tb)


@numba.njit(cache=True)
def soil_step(heights, strength, grid, mj_arrays, bucket_vel6, bucket, edge, surface, table, rocks, params, dt_s,
              state, pressure, out, box_body, early_out):
    """One control step of the bucket-soil interaction (see :mod:`excavsim.world.soil`).

    Cuts the swept cells; updates the state (previous edge, cutting force and failure cycle,
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
        box_body, early_out: (2, 3) low and high corners, body frame, of a box holding every
            sample of the bucket (surface, edge, edge ends) [m]; whether to skip the cutting and
            bearing loops while the bucket is clear of the terrain (:func:`clear_of_terrain`),
            writing exactly what they would (no cut, zero bearing pressures and forces): the
            results are the same to the bit either way.

    Returns:
        whether the step took that early-out.
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
    ew = np.empty((nw, 3))
    cx, cy, cz, dsum, d2sum = edge_depths(h, x0, y0, cell, z0, org, rot, edge, ax, ay, ew)
    depth = dsum / nw
    ends = edge_ends(org, rot, ends_body)
    if not st.has_prev:
        remember_edge(st, ends, cx, cy, cz)
        st.has_prev = True
    prev_c = st.prev_edge_centre_m
    travel = -((cx - prev_c[0]) * ux + (cy - prev_c[1]) * uy + (cz - prev_c[2]) * uz)
    speed = max(travel, 0.0) / dt_s

    # the edge's horizontal advance into the soil: the speed at which soil enters the wedge
    advance = (cx - prev_c[0]) * ax + (cy - prev_c[1]) * ay
    v_adv = max(advance, 0.0) / dt_s

    # wedge failure force: eq. 8 + adhesion + the surcharge heaped ahead (static), with the rate
    # effect on cohesion and the inertial term of the dynamic earthmoving equation
    f_fail = 0.0
    f_inert = 0.0
    f_nom = 0.0
    wedge_len = 0.0
    hetero = 1.0
    spacing = 1.0
    if depth > 0.0:
        rk = max(rake, p.rake_min_rad)
        ng = _interp_uniform(t_rake0, t_step, table.n_gamma, rk)
        nc = _interp_uniform(t_rake0, t_step, table.n_c, rk)
        nadh = _interp_uniform(t_rake0, t_step, table.n_a, rk)
        den = _interp_uniform(t_rake0, t_step, table.denominator, rk)
        beta = _interp_uniform(t_rake0, t_step, table.beta_rad, rk)
        nacc = _interp_uniform(t_rake0, t_step, table.n_acc, rk)
        dw = bk.width_m / nw
        rate = 1.0
        if v_adv > p.rate_reference_speed_m_s:
            rate += p.cohesion_rate_per_decade * np.log10(v_adv / p.rate_reference_speed_m_s)
        f_static = (p.gamma_g_n_m3 * d2sum * ng + rate * (p.cohesion_pa * nc + p.adhesion_pa * nadh) * dsum) * dw
        f_inert = p.density_kg_m3 * v_adv * v_adv * nacc * dsum * dw
        spacing = depth / np.tan(beta)
        wedge_len = depth / np.tan(rk) + spacing
        ex = ends[1, 0] - ends[0, 0]
        ey = ends[1, 1] - ends[0, 1]
        ez = ends[1, 2] - ends[0, 2]
        en = max(np.sqrt(ex * ex + ey * ey + ez * ez), 1e-9)
        centre = np.array([cx, cy, cz])
        across = np.array([ex / en, ey / en, ez / en])
        ahead = np.array([ax, ay, 0.0])
        v_ahead = surcharge_volume(h, g, centre, across, ahead, bk.width_m, wedge_len, cz + depth)
        v_load = p.load_surcharge * load_surcharge_volume(st.load_m3, p.capacity_m3)
        f_static += p.gamma_g_n_m3 * (v_ahead + v_load) / den
        # the strength of the soil the failure plane runs through, at its middle (interpolated)
        hs = bilinear(strength, x0, y0, cell, cx + 0.5 * spacing * ax, cy + 0.5 * spacing * ay)
        if np.isfinite(hs):
            hetero = hs
        f_nom = f_static + f_inert
        f_fail = f_static * hetero + f_inert
    fc, failed_now = failure_cycle(st, p, travel, advance, f_nom, f_fail, max(spacing, 1e-3))
    fcx, fcy, fcz = fc * ux, fc * uy, fc * uz

    # cut the swept cells
    prev_ends = st.prev_edge_ends_m
    clear = early_out and clear_of_terrain(h, g, org, rot, box_body, prev_ends)
    if clear:  # nothing above the edge's path: cut_swept would change no cell
        removed = 0.0
        win = o.window
        win[0] = h.shape[0]
        win[1] = -1
        win[2] = h.shape[1]
        win[3] = -1
    else:
        removed = cut_swept(h, g, prev_ends[0], prev_ends[1], ends[0], ends[1], o.window)
    cut = removed * cell * cell
    take = min(cut, max(p.capacity_m3 - st.load_m3, 0.0))
    st.load_m3 += take
    remember_edge(st, ends, cx, cy, cz)

    # bearing and friction on the outer surface
    n = surface.shape[0]
    fb = np.zeros(3)
    tb = np.zeros(3)
    if clear:  # every sample above the surface: bearing would zero each pressure and sum no force
        for k in range(n):
            pressure[k] = 0.0
        pmax = 0.0
    else:
        pmax = _bearing_step(h, g, org, rot, com, omega, v_org, surface, pressure, dt_s, p, fb, tb)

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
    o.advance_speed_m_s = v_adv
    o.wedge_failure_force_n = f_fail
    o.inertial_force_n = f_inert
    o.wedge_failed = 1.0 if failed_now else 0.0
    o.wedge_length_m = wedge_len
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
    return clear
