"""DiMaio's bucket-ground interaction model as the world's soil force (DiMaio 1998 ch. 5).

Selected by ``truth.model: dimaio`` in ``configs/scene.yaml`` (or ``scene: {truth: {model: dimaio}}``
in an episode specification); the wedge model (:mod:`excavsim.world.kernels`) stays the default.
The parameters are the soil preset's ``dimaio`` block (:class:`~excavsim.config.soils.DiMaioParams`).

The model (§5.1-5.2). A flat cutting surface of length ``s_bucket`` ends at the cutting edge
``p = (r, z)`` in the arm plane (r radial from the waist axis, z up); its unit tangent ``t`` (the
tip frame's ``x_t``, from heel to edge) and normal ``n`` (``z_t``, into the bucket) form the bucket
frame of Fig. 5.27, the rotation ``R(alpha)``. It penetrates the soil by ``s_p``. Four forces act:

* **Viscous friction** (eqs. 5.41-5.43): ``f_b = -R B R^T v`` with ``B = diag(s_p b_t0, s_p b_n0)``,
  i.e. ``f_bt = -s_p b_t0 v_t``, ``f_bn = -s_p b_n0 v_n``; ``tau_ba = -s_p b_a0 alpha_dot``.
* **Stiffness about a lagging centre** (eqs. 5.44, 5.46): ``[f_kt, f_kn] = k R^T (p_c - p)``,
  ``tau_ka = -k_a (alpha - alpha_c)``; the centre follows the edge through first-order lags of time
  constants ``T_rt``, ``T_rn`` along t and n. **Shear failure** (eq. 5.45): when
  ``|f_kn| >= S w d_p`` (``w`` the bucket width, ``d_p`` the distance from the edge to the surface
  along the normal) the stiffness is relieved: the centre is reset to the edge.
* **The accumulated load** (eqs. 5.47-5.48): ``f_lr = epsilon V``, ``f_lz = -rho g V``, acting at the
  centre of the cutting surface (``s_bucket / 2`` from the edge), so its moment about the edge is
  ``(s_bucket / 2) (f_lz cos alpha - f_lr sin alpha)``, eq. 5.47's ``tau_la``.
* **Coulomb friction** (eq. 5.49): ``f_ct = -mu |f_bn + f_kn + f_ln| v_t / |v_t|``.

Velocities are backward differences over the control step (§5.1: "computed by numerical
differentiation"). Discretization and where the thesis is silent (each **assumed**):

* the lag of eq. 5.46 is a backward-Euler step per control period ``T_s``: the centre's offset
  ``e = p_c - p`` first moves with the edge (``e -= dp``), then its components along the current
  ``t`` and ``n`` are scaled by ``a = T / (T + T_s)``; the offset is kept as a point in the arm
  plane, so a turning bucket carries it along (eq. 5.46 filters ``R^T(alpha) [r, z]``, which for a
  constant ``alpha`` is the same);
* the orientation centre ``alpha_c`` lags too, with its own time constant ``T_ra`` (eq. 5.46 lags
  ``r, z`` only; without a lag a curl in the soil winds the angular spring up until it shears);
* the shear test uses the magnitude ``|f_kn|`` (the sign of "exceeds" depends on the normal's sense);
  on shear the stiffness forces of that step are zero;
* ``s_p`` is the mean depth of the edge below the surface (the wedge kernel's depth, a probe two
  cells ahead), at most ``s_bucket``; ``d_p = s_p / |n_z|``, at most ``s_bucket``;
* the load ``V`` is the soil the cut put in the bucket (the grid's account: eq. 5.48's swept area
  times width, up to the heaped capacity); its weight acts always, its accumulation force
  ``epsilon V``, along +r as in eq. 5.47, only while the edge is in the soil; viscous, stiffness and
  Coulomb forces act only in the soil, and out of it the stiffness centre is reset to the edge;
* the Coulomb direction ``v_t / |v_t|`` is regularized to ``v_t / max(|v_t|, v_eps)`` (the scene's
  ``bucket.friction_velocity_m_s``) so that a once-per-step explicit force stays stable;
* there is no bearing on the bucket's outer surface (the thesis' single cutting surface), and the
  wedge's truth terms (speed, saw-tooth, heterogeneity) and rocks are not applied: the shear resets
  make their own saw-tooth. F/T noise is added by the Simulation as for the wedge.

The grid is cut exactly as with the wedge (:func:`~excavsim.world.grid_kernels.cut_swept`, the same
capacity and spill), so the volume account is exact with either truth. :func:`planar_step` is the
model in the arm plane, shared by the world's compiled step (:func:`dimaio_step`) and by the planar
simulator of the identification experiment (:func:`simulate_planar`, Fig. 5.34).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from excavsim.config import SceneConfig, SoilParams
from excavsim.errors import ConfigError
from excavsim.world import soil_records
from excavsim.world.grid_kernels import cut_swept
from excavsim.world.kernels import edge_depths, edge_ends, remember_edge

G_M_S2 = 9.81  # gravity of the planar simulator (the world's is MuJoCo's)


def params_record(dm, *, density_kg_m3: float, width_m: float, v_eps_m_s: float, gravity: float = G_M_S2,
                  never_shear: bool = False) -> np.ndarray:
    """The :data:`~excavsim.world.soil_records.DIMAIO_PARAMS` record of a
    :class:`~excavsim.config.soils.DiMaioParams` (``never_shear``: a threshold no force reaches)."""
    return soil_records.filled(
        soil_records.DIMAIO_PARAMS, b_t0=dm.viscous_tangential_n_s_m2, b_n0=dm.viscous_normal_n_s_m2,
        b_a0=dm.viscous_angular_n_s, k=dm.stiffness_n_m, k_a=dm.angular_stiffness_nm_rad, t_rt=dm.relax_tangential_s,
        t_rn=dm.relax_normal_s, t_ra=dm.relax_angular_s, shear_s=math.inf if never_shear else dm.shear_strength_pa,
        eps=dm.accumulation_n_m3, mu=dm.friction_coefficient, rho_g=density_kg_m3 * gravity,
        s_bucket=dm.cutting_surface_m, width=width_m, v_eps=v_eps_m_s)


def soil_dimaio(soil: SoilParams, name: str = "the soil"):
    """The soil's DiMaio parameters.

    Raises:
        ConfigError: the preset has no ``dimaio`` block.
    """
    if soil.dimaio is None:
        raise ConfigError(f"truth.model is dimaio but {name} has no 'dimaio' parameters in its preset "
                          "(configs/soils.yaml gives them for every preset)")
    return soil.dimaio


@numba.njit(cache=True)
def planar_step(params, state, tr, tz, nr, nz, dr, dz, dalpha, sp, dp, load_v, dt, out):
    """One step of the model in the arm plane (eqs. 5.41-5.49; see the module docstring).

    Args:
        params, state: the DIMAIO_PARAMS record and the DIMAIO_STATE record (updated), each ``(1,)``.
        tr, tz, nr, nz: the cutting surface's unit tangent ``t`` and normal ``n``, (r, z) components.
        dr, dz, dalpha: how far the edge moved and the bucket turned since the last step [m, rad].
        sp, dp: penetration and distance from the edge to the surface along ``n`` [m] (0: out of the soil).
        load_v: the load in the bucket [m^3].
        dt: the step [s].
        out: the DIMAIO_OUT record ``(1,)``, every field written.
    """
    p = params[0]
    st = state[0]
    o = out[0]
    vt = (dr * tr + dz * tz) / dt
    vn = (dr * nr + dz * nz) / dt
    adot = dalpha / dt
    # the load (eq. 5.47): accumulation along +r in the soil, weight always
    flr = p.eps * load_v if sp > 0.0 else 0.0
    flz = -p.rho_g * load_v
    flt = flr * tr + flz * tz
    fln = flr * nr + flz * nz
    fbt = fbn = fkt = fkn = fct = tb = tk = 0.0
    threshold = p.shear_s * p.width * dp
    sheared = 0.0
    if sp > 0.0:
        # lagging stiffness centre (eq. 5.46, backward Euler) and stiffness (eq. 5.44)
        a_t = p.t_rt / (p.t_rt + dt)
        a_n = p.t_rn / (p.t_rn + dt)
        a_a = p.t_ra / (p.t_ra + dt)
        er = st.offset_rz[0] - dr
        ez = st.offset_rz[1] - dz
        et = a_t * (er * tr + ez * tz)
        en = a_n * (er * nr + ez * nz)
        st.offset_rz[0] = et * tr + en * nr
        st.offset_rz[1] = et * tz + en * nz
        st.alpha_rel = a_a * (st.alpha_rel + dalpha)
        fkt = p.k * et
        fkn = p.k * en
        tk = -p.k_a * st.alpha_rel
        if abs(fkn) >= threshold:  # shear failure (eq. 5.45): the stiffness is relieved
            st.offset_rz[0] = 0.0
            st.offset_rz[1] = 0.0
            st.alpha_rel = 0.0
            fkt = fkn = tk = 0.0
            sheared = 1.0
        # viscous friction (eqs. 5.41-5.43)
        fbt = -sp * p.b_t0 * vt
        fbn = -sp * p.b_n0 * vn
        tb = -sp * p.b_a0 * adot
        # Coulomb friction (eq. 5.49) on the whole normal force
        fn_all = fbn + fkn + fln
        fct = -p.mu * abs(fn_all) * vt / max(abs(vt), p.v_eps)
    else:
        st.offset_rz[0] = 0.0
        st.offset_rz[1] = 0.0
        st.alpha_rel = 0.0
    tip_t = fbt + fkt + fct
    tip_n = fbn + fkn
    o.viscous_tn[0] = fbt
    o.viscous_tn[1] = fbn
    o.stiffness_tn[0] = fkt
    o.stiffness_tn[1] = fkn
    o.coulomb_t = fct
    o.load_rz[0] = flr
    o.load_rz[1] = flz
    o.tip_force_rz[0] = tip_t * tr + tip_n * nr
    o.tip_force_rz[1] = tip_t * tz + tip_n * nz
    o.force_rz[0] = o.tip_force_rz[0] + flr
    o.force_rz[1] = o.tip_force_rz[1] + flz
    o.force_tn[0] = tip_t + flt
    o.force_tn[1] = tip_n + fln
    o.torque_pure = tb + tk
    # the load at the centre of the cutting surface, s_bucket / 2 behind the edge along -t
    hr = -0.5 * p.s_bucket * tr
    hz = -0.5 * p.s_bucket * tz
    o.torque_tip = tb + tk + hr * flz - hz * flr
    o.threshold_n = threshold
    o.sheared = sheared
    o.sp_m = sp
    o.dp_m = dp
    o.v_t = vt
    o.v_n = vn


@numba.njit(cache=True)
def dimaio_step(heights, grid, mj_arrays, bucket, edge, waist_xy, params, dparams, dt_s, state, dstate, out, dout):
    """One control step of the world's soil with DiMaio's model (see the module docstring).

    Cuts the swept cells and fills the bucket as :func:`~excavsim.world.kernels.soil_step` does
    (the same STATE record: previous edge, load), then computes the model's wrench on the bucket
    about its centre of mass. ``out`` is the OUT record the Simulation reads (``cutting_force_n``:
    the forces at the edge; ``bearing_force_n`` and ``rock_force_n`` zero; ``wedge_failure_force_n``:
    the shear threshold); ``dout`` the model's own DIMAIO_OUT record. ``waist_xy`` (2,): the waist
    axis, from which r is measured.
    """
    h = heights
    g = grid[0]
    x0, y0, cell = g.x0_m, g.y0_m, g.cell_m
    xpos, xmat, xipos, site_xmat = mj_arrays
    bk = bucket[0]
    p = params[0]
    dp_ = dparams[0]
    st = state[0]
    ds = dstate[0]
    o = out[0]
    body = bk.body_id
    rot = xmat[body].reshape(3, 3)
    org = xpos[body]
    com = xipos[body]
    tip = site_xmat[bk.tip_site_id].reshape(3, 3)
    x_t = np.array([tip[0, 0], tip[1, 0], tip[2, 0]])
    z_t = np.array([tip[0, 2], tip[1, 2], tip[2, 2]])
    nw = edge.shape[0]
    ends_body = bk.edge_ends_m
    # the horizontal direction the edge cuts along (x_t's), where the depth is probed
    ax, ay = x_t[0], x_t[1]
    na = np.hypot(ax, ay)
    if na < 1e-6:
        ax, ay = z_t[0], z_t[1]
        na = max(np.hypot(ax, ay), 1e-9)
    ax /= na
    ay /= na
    rake = np.arctan2(-x_t[2], z_t[2])
    cx, cy, cz, dsum, _ = edge_depths(h, x0, y0, cell, g.z0_m, org, rot, edge, ax, ay, np.empty((nw, 3)))
    depth = dsum / nw
    ends = edge_ends(org, rot, ends_body)
    if not st.has_prev:
        remember_edge(st, ends, cx, cy, cz)
        st.has_prev = True
    prev_c = st.prev_edge_centre_m
    # the arm plane: r horizontal from the waist axis through the edge, z up
    rx, ry = cx - waist_xy[0], cy - waist_xy[1]
    rn = max(np.hypot(rx, ry), 1e-9)
    rx /= rn
    ry /= rn
    dr = (cx - prev_c[0]) * rx + (cy - prev_c[1]) * ry
    dz = cz - prev_c[2]
    tr, tz = x_t[0] * rx + x_t[1] * ry, x_t[2]
    tn = max(np.hypot(tr, tz), 1e-9)
    tr /= tn
    tz /= tn
    nr, nz = z_t[0] * rx + z_t[1] * ry, z_t[2]
    nn = max(np.hypot(nr, nz), 1e-9)
    nr /= nn
    nz /= nn
    dalpha = 0.0
    if ds.has_prev_t:
        pr, pz = ds.prev_t_rz[0], ds.prev_t_rz[1]
        dalpha = np.arctan2(pr * tz - pz * tr, pr * tr + pz * tz)
    ds.prev_t_rz[0] = tr
    ds.prev_t_rz[1] = tz
    ds.has_prev_t = True

    # cut the swept cells and fill the bucket (as the wedge kernel)
    removed = cut_swept(h, g, st.prev_edge_ends_m[0], st.prev_edge_ends_m[1], ends[0], ends[1], o.window)
    cut = removed * cell * cell
    take = min(cut, max(p.capacity_m3 - st.load_m3, 0.0))
    st.load_m3 += take
    for i in range(3):
        st.prev_edge_ends_m[0, i] = ends[0, i]
        st.prev_edge_ends_m[1, i] = ends[1, i]
    st.prev_edge_centre_m[0] = cx
    st.prev_edge_centre_m[1] = cy
    st.prev_edge_centre_m[2] = cz

    sp = min(depth, dp_.s_bucket)
    dpn = min(depth / max(abs(nz), 1e-6), dp_.s_bucket) if depth > 0.0 else 0.0
    planar_step(dparams, dstate, tr, tz, nr, nz, dr, dz, dalpha, sp, dpn, st.load_m3, dt_s, dout)
    do = dout[0]

    # back to the world: the edge forces at the edge centre, the load at the cutting surface's centre
    fx = do.tip_force_rz[0] * rx
    fy = do.tip_force_rz[0] * ry
    fz = do.tip_force_rz[1]
    lx = do.load_rz[0] * rx
    ly = do.load_rz[0] * ry
    lz = do.load_rz[1]
    half = 0.5 * dp_.s_bucket
    qx, qy, qz = cx - half * x_t[0] - com[0], cy - half * x_t[1] - com[1], cz - half * x_t[2] - com[2]
    ex, ey, ez = cx - com[0], cy - com[1], cz - com[2]
    # the pure torque about the across axis r x z = (ry, -rx, 0)
    tq = do.torque_pure
    o.load_weight_z_n = do.load_rz[1]
    o.depth_m = depth
    o.rake_rad = rake
    o.cutting_speed_m_s = do.v_t
    o.wedge_failure_force_n = do.threshold_n
    o.wedge_length_m = 2.0 * depth  # where a full bucket's spill lands (assumed: two depths ahead)
    o.cutting_force_n[0] = fx
    o.cutting_force_n[1] = fy
    o.cutting_force_n[2] = fz
    for i in range(3):
        o.bearing_force_n[i] = 0.0
        o.rock_force_n[i] = 0.0
    o.force_n[0] = fx + lx
    o.force_n[1] = fy + ly
    o.force_n[2] = fz + lz
    o.torque_nm[0] = ey * fz - ez * fy + qy * lz - qz * ly + tq * ry
    o.torque_nm[1] = ez * fx - ex * fz + qz * lx - qx * lz - tq * rx
    o.torque_nm[2] = ex * fy - ey * fx + qx * ly - qy * lx
    o.cut_volume_m3 = cut
    o.taken_volume_m3 = take
    o.max_penetration_m = depth
    o.ahead[0] = ax
    o.ahead[1] = ay
    o.ahead[2] = 0.0
    o.edge_centre_m[0] = cx
    o.edge_centre_m[1] = cy
    o.edge_centre_m[2] = cz


class DiMaioForces:
    """The world's DiMaio step for a :class:`~excavsim.world.soil.SoilModel` (its records and state).

    Args:
        soil: the soil preset (its ``dimaio`` block and density).
        scene: the scene configuration (the Coulomb regularization speed).
        width: the bucket's width [m].
        gravity: the model's gravity [m/s^2].
        waist_xy: (2,) the waist axis in the world [m].
    """

    def __init__(self, soil: SoilParams, scene: SceneConfig, width: float, gravity: float, waist_xy: np.ndarray):
        dm = soil_dimaio(soil, f"soil {soil.description[:40]!r}" if soil.description else "the soil")
        self.params = params_record(dm, density_kg_m3=soil.density_kg_m3, width_m=width,
                                    v_eps_m_s=scene.bucket.friction_velocity_m_s, gravity=gravity)
        self.state = np.zeros(1, soil_records.DIMAIO_STATE)
        self.out = np.zeros(1, soil_records.DIMAIO_OUT)
        self.waist_xy = np.ascontiguousarray(waist_xy, dtype=float)

    @property
    def half_surface_m(self) -> float:
        """Half the cutting surface's length: where the load acts, behind the edge [m]."""
        return 0.5 * float(self.params["s_bucket"][0])


def trajectory_fig_5_34(n: int = 1800, dt: float = 0.01, *, centre=(5.0, 1.0), radius: float = 1.5,
                        sweep_deg: float = 70.0, attack_deg: float = 20.0) -> dict[str, np.ndarray]:
    """A digging trajectory like Fig. 5.34: the edge on a circular arc at constant speed, the cutting
    surface at a constant angle to the direction of motion (the thesis gives no numbers: the circle,
    its sweep and the angle are assumed). From ``+sweep_deg`` to ``-sweep_deg`` about the lowest
    point, towards the machine (r decreasing at the bottom); ground at z = 0.

    Returns:
        ``r``, ``z`` (n,) [m] and ``t``, ``n`` (n, 2) the cutting surface's tangent and normal in (r, z).
    """
    psi = np.radians(np.linspace(sweep_deg, -sweep_deg, n))
    r = centre[0] + radius * np.sin(psi)
    z = centre[1] - radius * np.cos(psi)
    u = np.stack([-np.cos(psi), -np.sin(psi)], axis=-1)  # direction of motion (dpsi < 0)
    a = math.radians(attack_deg)  # the surface pitched down into the soil from the motion
    t = np.stack([u[:, 0] * math.cos(a) + u[:, 1] * math.sin(a), -u[:, 0] * math.sin(a) + u[:, 1] * math.cos(a)],
                 axis=-1)
    nvec = np.stack([t[:, 1], -t[:, 0]], axis=-1)  # n = z_t: t turned by -90 deg, as the tip frame
    return {"r": r, "z": z, "t": t, "n": nvec, "dt": np.full(n, dt)}


def simulate_planar(params: np.ndarray, traj: dict[str, np.ndarray], *, ground_z: float = 0.0,
                    profile_step_m: float = 0.005) -> dict[str, np.ndarray]:
    """DiMaio's model along a planar trajectory over flat ground (the identification experiment, §5.5.1).

    The ground profile ``F_u(r)`` starts flat at ``ground_z`` and is lowered where the edge passes
    below it; the load is eq. 5.48, the swept area times the width. The penetration is the depth
    of the edge below the original ground (the edge moves into uncut soil), at most ``s_bucket``;
    ``d_p`` is it over ``|n_z|``, at most ``s_bucket``.

    Args:
        params: a DIMAIO_PARAMS record (``(1,)``).
        traj: ``r``, ``z`` (n,), ``t``, ``n`` (n, 2) and ``dt`` (n,) as :func:`trajectory_fig_5_34` gives.

    Returns:
        ``force_rz``, ``force_tn`` (n, 2) [N], ``torque_tip`` (n,) [N m], the inputs the identifier
        reads (``r``, ``z``, ``t``, ``n``, ``sp``, ``dp``, ``load``, ``dt``) and the components
        (``viscous_tn``, ``stiffness_tn``, ``coulomb_t``, ``load_rz``, ``sheared``).
    """
    r, z, t, nv, dt = (np.asarray(traj[k], dtype=float) for k in ("r", "z", "t", "n", "dt"))
    n = r.size
    pr = params[0]
    s_b = float(pr["s_bucket"])
    width = float(pr["width"])
    lo, hi = float(r.min()) - 0.1, float(r.max()) + 0.1
    grid_r = np.arange(lo, hi + profile_step_m, profile_step_m)
    surface = np.full(grid_r.size, ground_z)
    state = np.zeros(1, soil_records.DIMAIO_STATE)
    out = np.zeros(1, soil_records.DIMAIO_OUT)
    res = {k: np.zeros((n, 2)) for k in ("force_rz", "force_tn", "viscous_tn", "stiffness_tn", "load_rz")}
    res.update({k: np.zeros(n) for k in ("torque_tip", "coulomb_t", "sheared", "sp", "dp", "load")})
    load = 0.0
    for i in range(n):
        dr = r[i] - r[i - 1] if i else 0.0
        dz = z[i] - z[i - 1] if i else 0.0
        dalpha = 0.0
        if i:
            (a0, a1), (b0, b1) = t[i - 1], t[i]
            dalpha = math.atan2(a0 * b1 - a1 * b0, a0 * b0 + a1 * b1)
        # eq. 5.48: the profile swept between the last and this edge position is cut to the edge
        if i:
            a, b = sorted((r[i - 1], r[i]))
            sel = (grid_r >= a) & (grid_r <= b)
            if sel.any():
                zline = np.interp(grid_r[sel], [r[i - 1], r[i]] if r[i] >= r[i - 1] else [r[i], r[i - 1]],
                                  [z[i - 1], z[i]] if r[i] >= r[i - 1] else [z[i], z[i - 1]])
                cut = np.maximum(surface[sel] - zline, 0.0)
                load += width * float(cut.sum()) * profile_step_m
                surface[sel] -= cut
        depth = max(ground_z - z[i], 0.0)
        sp = min(depth, s_b)
        dp = min(depth / max(abs(nv[i, 1]), 1e-6), s_b) if depth > 0 else 0.0
        planar_step(params, state, t[i, 0], t[i, 1], nv[i, 0], nv[i, 1], dr, dz, dalpha, sp, dp, load, dt[i], out)
        o = out[0]
        for k in ("force_rz", "force_tn", "viscous_tn", "stiffness_tn", "load_rz"):
            res[k][i] = o[k]
        res["torque_tip"][i] = o["torque_tip"]
        res["coulomb_t"][i] = o["coulomb_t"]
        res["sheared"][i] = o["sheared"]
        res["sp"][i], res["dp"][i], res["load"][i] = sp, dp, load
    res.update(r=r, z=z, t=t, n=nv, dt=dt)
    return res
