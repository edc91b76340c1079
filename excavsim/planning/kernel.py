"""The compiled per-candidate evaluation of the trenching grid (numba; Singh 1995 ch. 4-6).

The same feasibility as :class:`~excavsim.planning.feasibility.Feasibility` with ``prune=True``
(:meth:`~excavsim.planning.feasibility.Feasibility.penetration_lines` and
:meth:`~excavsim.planning.feasibility.Feasibility.evaluate`, which stay the reference), for the
nominal force model (:class:`~excavsim.planning.predictor.WedgePredictor`, or any predictor with
its ``kernel_params``), written as scalar loops over one candidate at a time instead of numpy
arrays over all of them:

* per (k, alpha) line, its penetration samples every ``sample_spacing_m`` once (§3.4.2.2), then
  per d1 only the end point (prefix AND / max / sum), and the d1 pruning of §6.2.1
  (:func:`~excavsim.planning.feasibility.prune_along_d1`): the first penetration that cuts
  through the goal ends the line;
* per cell, the drag (eq. 1) sample by sample with the constraints cheapest first (§6.2.2:
  shaping §4.3.1, sensible §4.3.6 with the bucket outline inside the box's walls, volume §4.3.2,
  reachability §4.3.3 by table then exact IK, force §5.3 by eq. 8 with the surcharge rule and the
  load's weight through eq. 28), stopping at the first failure: that bounds d2;
* the curl (§3.4.2.4, the smallest reachable radius of Fig. 23) from that bound down in strides
  of four samples, then refined upwards, with the same rules as ``Feasibility.evaluate`` (the
  curl's feasibility is not monotone in d2), each curl given up at its first failing constraint;
* the peak torque ratio and the cumulative torque (eq. 43) of the whole dig.

Each pose's IK is solved once for both its reachability and its torques
(:func:`~excavsim.robot.fast.solve_pose`, :func:`~excavsim.robot.fast.pose_torques`). Every
formula repeats the reference's floating-point operations in the same order (numpy's pairwise sum
included), so that verdicts and numbers agree bit for bit wherever the transcendental functions
of numpy and of the compiled code agree (tests/planning/test_planner_kernel.py holds them equal). What the
kernel does not do: learned predictors (Python), ``prune=False`` (every constraint on every
sample, for figures), ``classify_limits`` (the search without the force constraint, Fig. 87);
``TrenchPlanner.plan`` uses the reference there.
"""

from __future__ import annotations

import dataclasses
import math

import numba
import numpy as np

from excavsim.planning.constraints import CONSTRAINTS
from excavsim.robot.fast import chain_lengths, pose_torques, solve_pose_turned

NO_DIG = -1  # as feasibility.NO_DIG
_CURL_STRIDE = 4  # as feasibility._CURL_STRIDE

# Indices of the packed scalars (see _scalars).
(DS, EPS, ZETA, OMEGA, END_PITCH, EXIT_PITCH, TOL_SHAPE, TOL_SURF, TD_REACH, VMAX, WIDTH, DENSITY,
 G_NEAR, G_FAR, G_ZREF, G_TAN_NEAR, G_TAN_FAR, G_BOTTOM, BOX_LO, BOX_HI,
 T_ZMIN, T_DZ, T_PMIN, T_DP,
 W_RAKE0, W_STEP, W_LO, W_HI, W_DELTA, W_GAMMA_G, W_COH, W_ADH, W_WIDTH, W_SHARE, W_CAP, W_FILL, N_SCALARS) = range(37)
# Counters (out_counts).
C_REACH, C_FORCE, C_CURLS = range(3)
# A pitch's terms (_terms): the pitch, its cosine and sine, the wrist link's turn with its cosine and sine, and
# the sine and cosine of the soil force's angle.
P_PITCH, P_COS, P_SIN, P_TH3, P_C3, P_S3, P_SA, P_CA, N_TERMS = range(9)
_SQRT2 = math.sqrt(2.0)
_MAX_FLOAT = float(np.finfo(np.float64).max)


def supports(predictor) -> bool:
    """Whether the kernel can compute ``predictor``'s forces: it hands over its wedge parameters."""
    return callable(getattr(predictor, "kernel_params", None))


@dataclasses.dataclass
class KernelResult:
    """What the kernel found for m cells (the grid's, or those asked for).

    Attributes:
        j, radius, volume, peak, cum: as :class:`~excavsim.planning.feasibility.CellVerdicts`.
        alive: (m,) cells evaluated (not pruned along d1; all of them when cells were asked for).
        masks: per constraint, (m,) as ``PlanResult.masks`` (the penetration's shaping and sensible
            verdicts included).
        counts: poses whose reachability and whose force were evaluated, and curls tried.
    """

    j: np.ndarray
    radius: np.ndarray
    volume: np.ndarray
    peak: np.ndarray
    cum: np.ndarray
    alive: np.ndarray
    masks: dict[str, np.ndarray]
    counts: dict[str, int]


# ---------------------------------------------------------------------------------------------- per pose
@numba.njit(cache=True)
def _surface(x, sx, sz):
    """The mapped surface at ``x``: ``np.interp(x, sx, sz)`` with numpy's arithmetic."""
    n = sx.size
    if math.isnan(x):
        return x
    if x < sx[0]:
        return sz[0]
    if x > sx[n - 1]:
        return sz[n - 1]
    j = int((x - sx[0]) * ((n - 1) / (sx[n - 1] - sx[0])))  # a guess on a uniform grid, then exact
    j = min(max(j, 0), n - 1)
    while j > 0 and sx[j] > x:
        j -= 1
    while j < n - 1 and sx[j + 1] <= x:
        j += 1
    if j == n - 1 or sx[j] == x:
        return sz[j]
    slope = (sz[j + 1] - sz[j]) / (sx[j + 1] - sx[j])
    r = slope * (x - sx[j]) + sz[j]
    if math.isnan(r):
        r = slope * (x - sx[j + 1]) + sz[j + 1]
        if math.isnan(r) and sz[j] == sz[j + 1]:
            r = sz[j]
    return r


@numba.njit(cache=True)
def _shaping(x, z, sc):
    """Shaping (§4.3.1): on or above the goal profile (``goal_profile``) within the tolerance."""
    goal = sc[G_ZREF]
    if x >= sc[G_NEAR] and x <= sc[G_FAR]:
        near = sc[G_ZREF] - (x - sc[G_NEAR]) * sc[G_TAN_NEAR]
        far = sc[G_ZREF] - (sc[G_FAR] - x) * sc[G_TAN_FAR]
        goal = max(max(near, far), sc[G_BOTTOM])
    return z >= goal - sc[TOL_SHAPE]


@numba.njit(cache=True)
def _in_box(x, c, s, sc, outline):
    """The whole bucket outline keeps the clearance from the box's walls (``SurfaceProfile.in_box``), at a
    pitch of cosine ``c`` and sine ``s``."""
    lo, hi = sc[BOX_LO], sc[BOX_HI]
    if not (x >= lo and x <= hi):
        return False
    if outline.shape[0]:
        for i in range(outline.shape[0]):
            px = x - outline[i, 0] * c - outline[i, 1] * s
            if not (px >= lo and px <= hi):
                return False
    return True


@numba.njit(cache=True)
def _sensible(x, z, t, sc, sx, sz, outline):
    """Sensible (§4.3.6) for a penetrate or drag pose: in the soil, within the tolerance, and inside the box."""
    return z <= _surface(x, sx, sz) + sc[TOL_SURF] and _in_box(x, t[P_COS], t[P_SIN], sc, outline)


@numba.njit(cache=True)
def _swept(x0, z0, x1, z1, sc, sx, sz):
    """Volume swept from one sample to the next (``action.swept``) [m^3]."""
    xm = 0.5 * (x1 + x0)
    zm = 0.5 * (z1 + z0)
    return max(_surface(xm, sx, sz) - zm, 0.0) * abs(x0 - x1) * sc[WIDTH]


@numba.njit(cache=True)
def _in_table(x, z, pitch, sc, x_lo, x_hi):
    """The reachability table's lookup (``ReachabilityTable.contains``, App. A1-3)."""
    fz = np.rint((z - sc[T_ZMIN]) / sc[T_DZ])
    fp = np.rint((pitch * (180.0 / math.pi) - sc[T_PMIN]) / sc[T_DP])
    if not (fz >= 0 and fz < x_lo.shape[0] and fp >= 0 and fp < x_lo.shape[1]):
        return False
    iz, ip = int(fz), int(fp)
    for k in range(x_lo.shape[2]):
        if x >= x_lo[iz, ip, k] and x <= x_hi[iz, ip, k]:
            return True
    return False


@numba.njit(cache=True)
def _wedge(depth, rake, volume, sc, ng, nc, na, den, sin_a, cos_a):
    """The nominal soil force (F_x, F_z) on the bucket (``WedgePredictor.predict``: eq. 8 and the surcharge)."""
    depth = max(depth, 0.0)
    if not depth > 0:
        return 0.0, -0.0
    rk = min(max(rake, sc[W_LO]), sc[W_HI])
    v = max(volume, 0.0)
    held = min(v, sc[W_CAP])
    q = sc[W_SHARE] * held + sc[W_FILL] * held * (held / sc[W_CAP]) + (v - held)
    u = (rk - sc[W_RAKE0]) / sc[W_STEP]
    n = ng.size
    if not (u >= -1e-9 and u <= n - 1 + 1e-9):
        return math.inf, -math.inf
    i = min(max(math.floor(u), 0.0), n - 2.0)
    t = u - i
    ii = int(i)
    f_ng = ng[ii] + t * (ng[ii + 1] - ng[ii])
    f_nc = nc[ii] + t * (nc[ii + 1] - nc[ii])
    per_width = sc[W_GAMMA_G] * (depth * depth) * f_ng + sc[W_COH] * depth * f_nc
    if sc[W_ADH] != 0.0:
        per_width = per_width + sc[W_ADH] * depth * (na[ii] + t * (na[ii + 1] - na[ii]))
    f = per_width * sc[W_WIDTH]
    if q > 0:
        f = f + sc[W_GAMMA_G] * q / (den[ii] + t * (den[ii + 1] - den[ii]))
    if not math.isfinite(f_ng):
        f = math.inf
    return f * sin_a, -f * cos_a  # a = rk + delta (_terms)


@numba.njit(cache=True)
def _finite_abs(t):
    """``np.nan_to_num(abs(t))``."""
    a = abs(t)
    return 0.0 if math.isnan(a) else min(a, _MAX_FLOAT)


@numba.njit(cache=True)
def _load(t, depth, vcum, ok, q0, q1, q2, sc, wedge, arm, load_tip, limits):
    """The largest torque/limit ratio (``inf`` where unreachable, NaN propagated as ``np.max`` does) and the
    sum of the absolute joint torques at a pose solved by IK, under the predicted force and the load (eq. 28)."""
    if not ok:
        return math.inf, 0.0
    fx, fz = _wedge(depth, t[P_PITCH], vcum, sc, wedge[0], wedge[1], wedge[2], wedge[3], t[P_SA], t[P_CA])
    t0, t1, t2 = pose_torques(arm, q0, q1, q2, fx, fz, 0.0, sc[DENSITY] * vcum, load_tip)
    r0, r1, r2 = abs(t0) / limits[0], abs(t1) / limits[1], abs(t2) / limits[2]
    if math.isnan(r0) or math.isnan(r1) or math.isnan(r2):
        ratio = math.nan
    else:
        ratio = max(max(r0, r1), r2)
    return ratio, (_finite_abs(t0) + _finite_abs(t1)) + _finite_abs(t2)  # objectives.torque_sum


@numba.njit(cache=True)
def _pairwise(a, n):
    """``a[:n].sum()`` in numpy's pairwise order (for n <= 128; longer halves first)."""
    if n < 8:
        res = 0.0
        for i in range(n):
            res += a[i]
        return res
    if n <= 128:
        r0, r1, r2, r3, r4, r5, r6, r7 = a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7]
        i = 8
        while i < n - (n % 8):
            r0 += a[i]
            r1 += a[i + 1]
            r2 += a[i + 2]
            r3 += a[i + 3]
            r4 += a[i + 4]
            r5 += a[i + 5]
            r6 += a[i + 6]
            r7 += a[i + 7]
            i += 8
        res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
        while i < n:
            res += a[i]
            i += 1
        return res
    n2 = n // 2
    n2 -= n2 % 8
    return _pairwise(a, n2) + _pairwise(a[n2:], n - n2)


@numba.njit(cache=True)
def _ik(x, z, t, arm, chain):
    """Exact elbow-up IK of a pose with the pitch terms ``t``; returns (ok, q0, q1, q2)."""
    return solve_pose_turned(arm, chain[0], chain[1], chain[2], chain[3], x, z, t[P_PITCH], t[P_TH3], t[P_C3],
                             t[P_S3])


@numba.njit(cache=True)
def _reach(x, z, t, sc, x_lo, x_hi, arm, chain):
    """Reachability (§4.3.3): the table first, then exact IK; returns (ok, q0, q1, q2)."""
    if not _in_table(x, z, t[P_PITCH], sc, x_lo, x_hi):
        return False, 0.0, 0.0, 0.0
    return _ik(x, z, t, arm, chain)


@numba.njit(cache=True)
def _terms(pitch, sc, arm, out):
    """The terms of ``pitch`` that every pose at that pitch needs (P_*), into ``out``."""
    out[P_PITCH] = pitch
    out[P_COS], out[P_SIN] = math.cos(pitch), math.sin(pitch)
    th3 = pitch + math.pi - arm[11]  # as robot.fast.solve_pose
    out[P_TH3], out[P_C3], out[P_S3] = th3, math.cos(th3), math.sin(th3)
    a = min(max(pitch, sc[W_LO]), sc[W_HI]) + sc[W_DELTA]  # as _wedge's clipped rake
    out[P_SA], out[P_CA] = math.sin(a), math.cos(a)


@numba.njit(cache=True)
def _tables(grid_alpha, n_j, frac, sc, arm):
    """The pitch terms of the whole search: every pitch is a function of alpha and the drag sample.

    Returns ``pen`` (n_alpha, N_TERMS) of the penetrations (rake alpha + epsilon), ``drag`` (n_alpha, n_j,
    N_TERMS) of the drag samples (eq. 1) and ``curl`` (n_alpha, n_j, M, 2 + N_TERMS): the cosine and sine
    of the curl's turn at each of its M samples from drag sample j, then that sample's pitch terms.
    """
    na, m_n = grid_alpha.size, frac.size
    pen = np.empty((na, N_TERMS))
    drag = np.empty((na, n_j, N_TERMS))
    crl = np.empty((na, n_j, m_n, 2 + N_TERMS))
    ds = sc[DS]
    for ia in range(na):
        rho = grid_alpha[ia] + sc[EPS]
        _terms(rho, sc, arm, pen[ia])
        for j in range(n_j):
            rho0 = max(sc[ZETA], rho - sc[OMEGA] * (j * ds))
            _terms(rho0, sc, arm, drag[ia, j])
            turn = max(rho0 - sc[END_PITCH], 0.0)
            for m in range(m_n):
                th = turn * frac[m]
                crl[ia, j, m, 0], crl[ia, j, m, 1] = math.cos(th), math.sin(th)
                _terms(rho0 - th, sc, arm, crl[ia, j, m, 2:])
    return pen, drag, crl


# ---------------------------------------------------------------------------------------------- the curl
@numba.njit(cache=True)
def _curl(x0, z0, vb, td, tc, sc, radii, sx, sz, outline, x_lo, x_hi, arm, chain, load_tip, limits, wedge,
          scratch, counts):
    """The curl from a drag end pose (§3.4.2.4) with its smallest reachable radius (Fig. 23), and whether it
    passes every constraint (``Feasibility._curls``), given up at the first that fails.

    Args:
        x0, z0, vb: the drag end's position and the volume swept so far; td: its pitch terms; tc: the curl's
            (M, 2 + N_TERMS) from it (:func:`_tables`).

    Returns:
        ``(ok, radius, volume, peak, cum)``: the curl's own swept volume, peak torque ratio and cumulative
        torque (eq. 43); radius 0 when no radius reaches.
    """
    counts[C_CURLS] += 1
    m_n = tc.shape[0]
    cr, sr = td[P_COS], td[P_SIN]
    ux = (cr - sr) / _SQRT2
    uz = (sr + cr) / _SQRT2
    c, s = tc[m_n - 1, 0], tc[m_n - 1, 1]
    radius = -1.0
    end_q0 = end_q1 = end_q2 = 0.0
    for r in radii:
        cx = x0 + r * ux
        cz = z0 + r * uz
        vx, vz = x0 - cx, z0 - cz
        counts[C_REACH] += 1
        ok, end_q0, end_q1, end_q2 = _reach(cx + c * vx + s * vz, cz - s * vx + c * vz, tc[m_n - 1, 2:], sc, x_lo,
                                            x_hi, arm, chain)
        if ok:
            radius = r
            break
    if radius < 0:
        return False, 0.0, 0.0, 0.0, 0.0
    cx = x0 + radius * ux
    cz = z0 + radius * uz
    vx, vz = x0 - cx, z0 - cz
    px, pz, vol = scratch[0], scratch[1], scratch[2]
    # shaping, sensible (the exit rule and the box), volume: the cheap ones, on every pose first
    exited = False
    run = 0.0
    for m in range(m_n):
        c, s = tc[m, 0], tc[m, 1]
        x = cx + c * vx + s * vz
        z = cz - s * vx + c * vz
        px[m], pz[m] = x, z
        if not _shaping(x, z, sc):
            return False, radius, 0.0, 0.0, 0.0
        if not exited and z > _surface(x, sx, sz) + sc[TOL_SURF]:
            exited = True  # the edge leaves the soil here: the bucket must have curled enough
            if not tc[m, 2 + P_PITCH] <= sc[EXIT_PITCH]:
                return False, radius, 0.0, 0.0, 0.0
        if not _in_box(x, tc[m, 2 + P_COS], tc[m, 2 + P_SIN], sc, outline):
            return False, radius, 0.0, 0.0, 0.0
        if m:
            run += _swept(px[m - 1], pz[m - 1], x, z, sc, sx, sz)
        vol[m] = vb + run
    if not vol[m_n - 1] <= sc[VMAX]:
        return False, radius, 0.0, 0.0, 0.0
    # reachability and force, one IK per pose (the end pose's from the radius search)
    peak = -math.inf
    seg = scratch[3]
    for m in range(m_n):
        t = tc[m, 2:]
        if m == m_n - 1:
            ok, q0, q1, q2 = True, end_q0, end_q1, end_q2
        else:
            counts[C_REACH] += 1
            ok, q0, q1, q2 = _reach(px[m], pz[m], t, sc, x_lo, x_hi, arm, chain)
            if not ok:
                return False, radius, 0.0, 0.0, 0.0
        counts[C_FORCE] += 1
        depth = max(_surface(px[m], sx, sz) - pz[m], 0.0)
        ratio, tsum = _load(t, depth, vol[m], ok, q0, q1, q2, sc, wedge, arm, load_tip, limits)
        if not ratio <= 1.0:
            return False, radius, 0.0, 0.0, 0.0
        peak = max(peak, ratio)
        if m:
            dx, dz = px[m] - px[m - 1], pz[m] - pz[m - 1]
            seg[m - 1] = tsum * math.sqrt(dx * dx + dz * dz)
    return True, radius, vol[m_n - 1] - vb, peak, _pairwise(seg, m_n - 1)


# ---------------------------------------------------------------------------------------------- a line
@numba.njit(cache=True)
def _line(k, ca, sa, zk, tp, n_s, sc, sx, sz, outline, x_lo, x_hi, arm, chain, load_tip, limits, wedge, ln, counts):
    """The penetration samples of one (k, alpha) line every ``sample_spacing_m`` (``penetration_lines``);
    ``tp``: the pitch terms of its rake.

    Fills ``ln`` (10, n_s): x, z, then per sample the prefix AND of shaping, sensible and reachability,
    the swept volume so far, the prefix peak torque ratio, the cumulative torque of the samples after the
    first (the spacing as each one's length) and the sample's own shaping and sensible verdicts. Returns
    whether the touch-down below the entry is reachable (§7.1.3).
    """
    ds = sc[DS]
    ok_shape = ok_sense = ok_reach = True
    peak = -math.inf
    for i in range(n_s):
        s = i * ds
        x = k - s * ca
        z = zk - s * sa
        sh = _shaping(x, z, sc)
        se = _sensible(x, z, tp, sc, sx, sz, outline)
        ok_shape = ok_shape and sh
        ok_sense = ok_sense and se
        counts[C_REACH] += 1
        counts[C_FORCE] += 1
        tab = _in_table(x, z, tp[P_PITCH], sc, x_lo, x_hi)
        ik, q0, q1, q2 = _ik(x, z, tp, arm, chain)
        ok_reach = ok_reach and tab and ik
        if i:
            ln[5, i] = ln[5, i - 1] + _swept(ln[0, i - 1], ln[1, i - 1], x, z, sc, sx, sz)
        else:
            ln[5, i] = 0.0
        depth = max(_surface(x, sx, sz) - z, 0.0)
        ratio, tsum = _load(tp, depth, ln[5, i], ik, q0, q1, q2, sc, wedge, arm, load_tip, limits)
        peak = max(peak, ratio if math.isfinite(ratio) else math.inf)
        ln[0, i], ln[1, i] = x, z
        ln[2, i], ln[3, i], ln[4, i] = ok_shape, ok_sense, ok_reach
        ln[6, i] = peak
        ln[7, i] = ln[7, i - 1] + tsum * ds if i else 0.0
        ln[8, i], ln[9, i] = sh, se
    counts[C_REACH] += 1
    return _reach(k, zk - sc[TD_REACH], tp, sc, x_lo, x_hi, arm, chain)[0]


# ---------------------------------------------------------------------------------------------- a cell
@numba.njit(cache=True)
def _cell(k, d1, ca, sa, zk, tp, tdr, tcu, n_s, n_j, entry_ok, ln, sc, radii, sx, sz, outline, x_lo, x_hi, arm,
          chain, load_tip, limits, wedge, drag, scratch, counts, c, out_j, out_f, out_m):
    """One cell (k, alpha, d1) of an evaluated line: its penetration's verdicts, its drag, its d2 and curl.

    ``tp``, ``tdr``, ``tcu``: the pitch terms of its alpha (:func:`_tables`). Writes the cell ``c`` of
    ``out_j`` (the drag samples of d2, ``NO_DIG`` where none), ``out_f`` (4, n): radius, volume, peak, cum
    (NaN where infeasible; radius 0) and ``out_m`` (5, n): the constraint masks.
    """
    ds = sc[DS]
    # the penetration: the line's samples before d1, then its end point (penetration_lines)
    last = min(max(math.ceil(d1 / ds - 1e-9), 1), n_s) - 1
    ex = k - d1 * ca
    ez = zk - d1 * sa
    p_shape = ln[2, last] != 0 and _shaping(ex, ez, sc)
    p_sense = ln[3, last] != 0 and _sensible(ex, ez, tp, sc, sx, sz, outline)
    p_vol = ln[5, last] + _swept(ln[0, last], ln[1, last], ex, ez, sc, sx, sz)
    counts[C_REACH] += 1
    counts[C_FORCE] += 1
    tab = _in_table(ex, ez, tp[P_PITCH], sc, x_lo, x_hi)
    ik, q0, q1, q2 = _ik(ex, ez, tp, arm, chain)
    p_reach = ln[4, last] != 0 and tab and ik and entry_ok
    depth = max(_surface(ex, sx, sz) - ez, 0.0)
    ratio_e, tsum_e = _load(tp, depth, p_vol, ik, q0, q1, q2, sc, wedge, arm, load_tip, limits)
    p_peak = math.inf
    if p_reach:
        pl = ln[6, last]
        p_peak = math.nan if math.isnan(ratio_e) or math.isnan(pl) else max(pl, ratio_e)
    p_force = p_peak <= 1.0
    dx, dz = ex - ln[0, last], ez - ln[1, last]
    p_cum = ln[7, last] + tsum_e * math.sqrt(dx * dx + dz * dz)
    # the drag from the padded penetration's last pose (TrenchPlanner.penetrate, drag)
    s_end = min((n_s - 1) * ds, d1)
    x0 = k - s_end * ca
    z0 = zk - s_end * sa
    dxs, dvs, dpeak, dcum = drag[0], drag[1], drag[2], drag[3]
    j_all = n_j
    run = 0.0
    acc = 0.0
    pk = -math.inf
    a0 = 0.0
    for j in range(n_j):
        t = tdr[j]
        x = x0 - j * ds
        if j:
            run += _swept(dxs[j - 1], z0, x, z0, sc, sx, sz)
        v = p_vol + run
        dxs[j], dvs[j] = x, v
        sh = _shaping(x, z0, sc)
        se = _sensible(x, z0, t, sc, sx, sz, outline)
        vo = v <= sc[VMAX]
        if j == 0:  # the masks judge the dig with the shortest drag (Feasibility.evaluate)
            out_m[0, c] = p_shape and sh
            out_m[1, c] = p_sense and se
            out_m[2, c] = vo
            out_m[3, c] = p_reach
            f0 = True
            if p_force and sh and se and vo:
                counts[C_FORCE] += 1
                ik0, r0, r1, r2 = _ik(x, z0, t, arm, chain)
                dep = max(_surface(x, sx, sz) - z0, 0.0)
                f0 = _load(t, dep, v, ik0, r0, r1, r2, sc, wedge, arm, load_tip, limits)[0] <= 1.0
            out_m[4, c] = p_force and f0
            if not (p_shape and p_sense and p_reach and p_force):
                return
        if not (sh and se and vo):
            j_all = j
            break
        counts[C_REACH] += 1
        ok, q0, q1, q2 = _reach(x, z0, t, sc, x_lo, x_hi, arm, chain)
        if not ok:
            j_all = j
            break
        counts[C_FORCE] += 1
        dep = max(_surface(x, sx, sz) - z0, 0.0)
        ratio, tsum = _load(t, dep, v, ok, q0, q1, q2, sc, wedge, arm, load_tip, limits)
        if not ratio <= 1.0:
            j_all = j
            break
        pk = max(pk, ratio)
        dpeak[j] = pk
        acc += tsum * ds
        if j == 0:
            a0 = tsum * ds
        dcum[j] = acc - a0
    # the longest drag whose curl passes: down from the bound in strides, then refined upwards
    hi = j_all - 1
    best, best_r, best_v, best_p, best_c = NO_DIG, 0.0, 0.0, 0.0, 0.0
    jj = hi
    while jj >= 0:
        ok, r, cv, cp, cc = _curl(dxs[jj], z0, dvs[jj], tdr[jj], tcu[jj], sc, radii, sx, sz, outline, x_lo, x_hi,
                                  arm, chain, load_tip, limits, wedge, scratch, counts)
        if ok:
            best, best_r, best_v, best_p, best_c = jj, r, cv, cp, cc
            break
        jj -= _CURL_STRIDE
    if best >= 0:
        for up in range(_CURL_STRIDE - 1, 0, -1):
            jj = min(best + up, hi)
            if jj > best:
                ok, r, cv, cp, cc = _curl(dxs[jj], z0, dvs[jj], tdr[jj], tcu[jj], sc, radii, sx, sz, outline, x_lo,
                                          x_hi, arm, chain, load_tip, limits, wedge, scratch, counts)
                if ok:
                    best, best_r, best_v, best_p, best_c = jj, r, cv, cp, cc
    if best < 0:
        return
    out_j[c] = best
    out_f[0, c] = best_r
    out_f[1, c] = dvs[best] + best_v
    prefix = max(p_peak, dpeak[best])
    out_f[2, c] = max(prefix, best_p)
    out_f[3, c] = p_cum + dcum[best] + best_c


# ---------------------------------------------------------------------------------------------- entry points
@numba.njit(cache=True)
def plan_grid(grid_k, grid_alpha, grid_d1, cos_a, sin_a, surf_k, n_s, n_j, sc, radii, frac, sx, sz, outline,
              x_lo, x_hi, arm, load_tip, limits, wedge, out_j, out_f, out_m, out_alive, counts):
    """Every cell of the (k, alpha, d1) grid, pruned along d1 at the first penetration that cuts
    through the goal (§6.2.1), in C order of the grid (see the module docstring)."""
    nk, na, nd = grid_k.size, grid_alpha.size, grid_d1.size
    chain = chain_lengths(arm)
    t_pen, t_drag, t_curl = _tables(grid_alpha, n_j, frac, sc, arm)
    ln = np.zeros((10, n_s))
    drag = np.zeros((4, n_j))
    scratch = np.zeros((4, frac.size))
    ds = sc[DS]
    for il in range(nk * na):
        ik, ia = il // na, il % na
        k, ca, sa, zk, tp = grid_k[ik], cos_a[ia], sin_a[ia], surf_k[ik], t_pen[ia]
        entry_ok = _line(k, ca, sa, zk, tp, n_s, sc, sx, sz, outline, x_lo, x_hi, arm, chain, load_tip, limits,
                         wedge, ln, counts)
        for id1 in range(nd):
            d1 = grid_d1[id1]
            # the padded penetration's shaping and sensible verdicts (TrenchPlanner.plan): the line's
            # samples short of d1, then d1 itself
            cnt = 0
            while cnt < n_s and cnt * ds < d1:
                cnt += 1
            ex, ez = k - d1 * ca, zk - d1 * sa
            full_shape = full_sense = True
            for i in range(cnt):
                full_shape = full_shape and ln[8, i] != 0
                full_sense = full_sense and ln[9, i] != 0
            if cnt < n_s:
                full_shape = full_shape and _shaping(ex, ez, sc)
                full_sense = full_sense and _sensible(ex, ez, tp, sc, sx, sz, outline)
            if not full_shape:
                break  # pruned: every longer penetration of the line contains this one
            c = il * nd + id1
            out_alive[c] = True
            _cell(k, d1, ca, sa, zk, tp, t_drag[ia], t_curl[ia], n_s, n_j, entry_ok, ln, sc, radii, sx, sz, outline,
                  x_lo, x_hi, arm, chain, load_tip, limits, wedge, drag, scratch, counts, c, out_j, out_f, out_m)
            out_m[1, c] = out_m[1, c] and full_sense


@numba.njit(cache=True)
def plan_cells(cells, grid_k, grid_alpha, grid_d1, cos_a, sin_a, surf_k, n_s, n_j, sc, radii, frac, sx, sz,
               outline, x_lo, x_hi, arm, load_tip, limits, wedge, out_j, out_f, out_m, counts):
    """The cells ``cells`` (m,) (flat indices in C order of the grid), unpruned, into outputs of length m;
    a line is evaluated once for consecutive cells on it (sort them for that)."""
    na, nd = grid_alpha.size, grid_d1.size
    chain = chain_lengths(arm)
    t_pen, t_drag, t_curl = _tables(grid_alpha, n_j, frac, sc, arm)
    ln = np.zeros((10, n_s))
    drag = np.zeros((4, n_j))
    scratch = np.zeros((4, frac.size))
    prev = -1
    entry_ok = False
    for c in range(cells.size):
        il, id1 = cells[c] // nd, cells[c] % nd
        ik, ia = il // na, il % na
        k, ca, sa, zk, tp = grid_k[ik], cos_a[ia], sin_a[ia], surf_k[ik], t_pen[ia]
        if il != prev:
            entry_ok = _line(k, ca, sa, zk, tp, n_s, sc, sx, sz, outline, x_lo, x_hi, arm, chain, load_tip, limits,
                             wedge, ln, counts)
            prev = il
        _cell(k, grid_d1[id1], ca, sa, zk, tp, t_drag[ia], t_curl[ia], n_s, n_j, entry_ok, ln, sc, radii, sx, sz,
              outline, x_lo, x_hi, arm, chain, load_tip, limits, wedge, drag, scratch, counts, c, out_j, out_f, out_m)


# ---------------------------------------------------------------------------------------------- Python side
def _inputs(feas, grid_k: np.ndarray, grid_alpha: np.ndarray, grid_d1: np.ndarray) -> tuple:
    """The kernel's arguments for a :class:`~excavsim.planning.feasibility.Feasibility` and a grid."""
    cfg, goal, surface, statics = feas.cfg, feas.goal, feas.surface, feas.statics
    w = feas.predictor.kernel_params()
    spec = statics.table.spec
    sc = np.zeros(N_SCALARS)
    sc[DS] = cfg.sample_spacing_m
    sc[EPS] = math.radians(cfg.epsilon_deg)
    sc[ZETA] = math.radians(cfg.zeta_deg)
    sc[OMEGA] = math.radians(cfg.omega_deg_per_m)
    sc[END_PITCH] = math.radians(cfg.curl_end_pitch_deg)
    sc[EXIT_PITCH] = math.radians(cfg.curl_exit_pitch_deg)
    sc[TOL_SHAPE] = cfg.shaping_tolerance_m
    sc[TOL_SURF] = cfg.surface_tolerance_m
    sc[TD_REACH] = cfg.touchdown_reach_m
    sc[VMAX] = feas.vmax
    sc[WIDTH] = feas.width
    sc[DENSITY] = feas.density
    sc[G_NEAR], sc[G_FAR], sc[G_ZREF] = goal.near_x_m, goal.far_x_m, goal.surface_z_m
    sc[G_TAN_NEAR] = math.tan(math.radians(goal.near_wall_deg))
    sc[G_TAN_FAR] = math.tan(math.radians(goal.far_wall_deg))
    sc[G_BOTTOM] = goal.surface_z_m - goal.depth_m
    sc[BOX_LO] = surface.x_in + surface.clearance_m
    sc[BOX_HI] = surface.x_out - surface.clearance_m
    sc[T_ZMIN], sc[T_DZ], sc[T_PMIN], sc[T_DP] = spec.z_min_m, spec.dz_m, spec.pitch_min_deg, spec.dpitch_deg
    for i, key in ((W_RAKE0, "rake0"), (W_STEP, "rake_step"), (W_LO, "rake_lo"), (W_HI, "rake_hi"),
                   (W_DELTA, "delta"), (W_GAMMA_G, "gamma_g"), (W_COH, "cohesion"), (W_ADH, "adhesion"),
                   (W_WIDTH, "width"), (W_SHARE, "share"), (W_CAP, "capacity"),
                   (W_FILL, "fill")):
        sc[i] = w[key]
    wedge = np.ascontiguousarray(np.stack([w["n_gamma"], w["n_c"], w["n_a"], w["denominator"]]), dtype=np.float64)
    ds = cfg.sample_spacing_m
    n_s = int(math.ceil(grid_d1.max() / ds)) + 1  # action.penetration_samples
    n_j = int(math.floor(cfg.d2_max_m / ds + 1e-9)) + 1  # TrenchPlanner.drag
    f64 = lambda a: np.ascontiguousarray(a, dtype=np.float64)  # noqa: E731
    outline = f64(np.asarray(surface.outline, dtype=float).reshape(-1, 2))
    return (f64(grid_k), f64(grid_alpha), f64(grid_d1), np.cos(f64(grid_alpha)), np.sin(f64(grid_alpha)),
            f64(surface(f64(grid_k))), n_s, n_j, sc, f64(cfg.curl_radii_m), np.linspace(0.0, 1.0, cfg.curl_samples),
            f64(surface.x), f64(surface.z), outline, f64(statics.table.x_lo), f64(statics.table.x_hi),
            f64(statics.params), f64(statics.load_tip), f64(feas.limits), wedge)


def _result(out_j, out_f, out_m, alive, counts) -> KernelResult:
    return KernelResult(out_j, out_f[0], out_f[1], out_f[2], out_f[3], alive,
                        {name: out_m[i] for i, name in enumerate(CONSTRAINTS)},
                        {"reach_samples": int(counts[C_REACH]), "force_samples": int(counts[C_FORCE]),
                         "curl_evaluations": int(counts[C_CURLS])})


def _outputs(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    out_f = np.full((4, n), np.nan)
    out_f[0] = 0.0
    return np.full(n, NO_DIG, dtype=np.int64), out_f, np.zeros((5, n), bool), np.zeros(3, np.int64)


def evaluate_grid(feas, grid_k: np.ndarray, grid_alpha: np.ndarray, grid_d1: np.ndarray) -> KernelResult:
    """Every cell of the grid on ``feas``'s map, as ``TrenchPlanner.plan(prune=True)`` judges them with the
    reference (``penetration_lines`` + ``evaluate`` after the d1 pruning), in C order of the grid."""
    n = len(grid_k) * len(grid_alpha) * len(grid_d1)
    out_j, out_f, out_m, counts = _outputs(n)
    alive = np.zeros(n, bool)
    plan_grid(*_inputs(feas, grid_k, grid_alpha, grid_d1), out_j, out_f, out_m, alive, counts)
    return _result(out_j, out_f, out_m, alive, counts)


def evaluate_cells(feas, grid_k: np.ndarray, grid_alpha: np.ndarray, grid_d1: np.ndarray,
                   cells: np.ndarray) -> KernelResult:
    """The cells ``cells`` (m,) (flat indices of the grid in C order) judged as :func:`evaluate_grid` judges
    them, without the d1 pruning (the caller prunes); results in the order of ``cells``."""
    cells = np.asarray(cells, dtype=np.int64)
    order = np.argsort(cells, kind="stable")
    out_j, out_f, out_m, counts = _outputs(cells.size)
    plan_cells(np.ascontiguousarray(cells[order]), *_inputs(feas, grid_k, grid_alpha, grid_d1), out_j, out_f, out_m,
               counts)
    back = np.empty_like(order)
    back[order] = np.arange(order.size)
    return _result(out_j[back], out_f[:, back], out_m[:, back], np.ones(cells.size, bool), counts)
