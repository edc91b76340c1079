"""Fitting a soil model to a force record of digs (``excavsim calibrate``; DiMaio 1998 §5.5, Singh 1995 eq. 8).

The record is the executor's F/T trace in the tip frame with the tip pose from the encoders, the
scanned surface ahead of the tip and the swept volume, at the F/T rate (``excavsim calibrate
--record-digs N``, ``excavsim learn --dataset FILE``, or a Rerun recording read by
:mod:`excavsim.record.reading` and :func:`~excavsim.apps.calibrate.digs.dataset_from_recording`).
What the fits model of the record (measured against the world's force components, the README's
calibration section):

* the load in the bucket is the swept volume, led by the soil just ahead of the tip, scaled per dig
  to the soil the scans saw the dig remove (:func:`~excavsim.learning.wedge_fit.load_profile`): the
  swept volume alone is 13-20 % short of the load, which made gamma 14 % high; the load is in the
  bucket, not on the wedge (the world's wedge carries only the soil heaped on it);
* the depth is the surface 5 cm ahead of the tip, and the soil above that level on the failure
  wedge ahead (the wall of the last dig) is surcharge (:class:`~excavsim.learning.wedge_fit.RecordWedge`),
  with McKyes' inertial term at the tip's advance speed;
* the first samples of a dig, the bucket rising off the touch-down with its bottom pressed on the
  soil (bearing, not cutting), are left out of every fit and score;
* DiMaio's model is stepped at the controller's rate between the F/T samples and its shear failure
  (eq. 5.45) is modelled, with the strength ``S`` fitted: without it the model misses the record by
  255 N RMS at the true parameters, with it by 68 N.

:func:`fit_wedge` fits ``c, phi, delta, gamma`` with bounds; :func:`fit_dimaio` the eight
parameters of Table 5.3 and ``S``; ``--fix NAME=VALUE`` (:func:`parse_fixes`) holds any of them at a
known value (a sand's c = 0: its records do not separate c from phi, the c-phi valley of
Singh's §5.2.4.1 along which the map's depth error slides the free fit) and fits the rest.
:func:`fitted_soil` and :func:`preset_yaml` turn a fit into a soil and its preset. The calibration
run that prints, writes and re-runs them is :mod:`~excavsim.apps.calibrate.run`.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from excavsim.errors import ConfigError
from excavsim.learning import identify
from excavsim.learning.dataset import ForceDataset

# Table 5.3's simulated values (DiMaio 1998 §5.5.1).
TABLE_5_3 = {"b_t0": 30000.0, "b_n0": 10000.0, "mu": 0.9, "eps": 10000.0, "rho": 2000.0, "k": 100000.0,
             "T_rt": 0.100, "T_rn": 0.500}
V_EPS = 0.02  # the Coulomb regularization speed of configs/scene.yaml (bucket.friction_velocity_m_s)
SEARCH_FACTORS = (1.0, 1.0 / 3.0, 3.0)  # DiMaio's search starts: the preset's stiffness, lags and shear times these
SUBSTEPS = 10  # DiMaio's model is stepped at the controller's rate (100 Hz) between the 10 Hz F/T samples


def _loads(data: ForceDataset, width: float) -> np.ndarray:
    from excavsim.learning.wedge_fit import load_profile
    from excavsim.apps.calibrate.digs import removed_volumes

    return load_profile(data["v"], data["dig"], removed_volumes(data), tip_depth_m=data["l1"], width_m=width)


def planar_record(data: ForceDataset, s_bucket: float, width: float) -> identify.PlanarRecord:
    """A force data set as the identifier's record: the tip pose's tangent ``x_t = (-cos p, -sin p)``
    and normal ``z_t = (-sin p, cos p)`` in (r, z); the depth the blade faces
    (:meth:`~excavsim.learning.wedge_fit.RecordWedge.depth`, at most ``s_bucket``) as the penetration;
    the load of :func:`~excavsim.learning.wedge_fit.load_profile`; one run per dig."""
    from excavsim.learning.wedge_fit import RecordWedge

    p = data["rake"]
    t = np.stack([-np.cos(p), -np.sin(p)], axis=-1)
    n = np.stack([-np.sin(p), np.cos(p)], axis=-1)
    times = data["t"]
    same = np.diff(data["dig"]) == 0
    dt = float(np.median(np.diff(times)[same])) if same.any() else 0.1
    load = _loads(data, width)
    sp = np.minimum(RecordWedge(width).depth(RecordWedge.inputs(data.samples, load)), s_bucket)
    return identify.PlanarRecord(data["x"], data["z"], t, n, sp, load, data.forces, dt, segment=data["dig"])


@dataclasses.dataclass
class Fit:
    """One model fitted to one record; scores over the samples the fit used."""

    model: str
    params: dict[str, float]
    errors: dict[str, float]
    predicted: np.ndarray  # (n, 2) along the tip frame's x and z [N], every sample
    rms_n: float
    r2: float
    # (wedge) the correlation of the estimates (c, phi, delta, gamma), and the range of phi the record
    # supports: its profile-likelihood interval at CONFIDENCE [deg], and the residuals' inflation tau
    correlation: np.ndarray | None = None
    phi_range_deg: tuple[float, float] | None = None
    fixed: dict[str, float] = dataclasses.field(default_factory=dict)  # the parameters held, not fitted
    brittleness: float = 0.0  # (wedge) I_B of the failure cycle the record model averages
    rate_per_decade: float = 0.0  # (wedge) the rate effect on cohesion the record model applies
    inflation: float = 1.0  # (wedge) residual_inflation of the fit's residuals
    smooth_share: float = 0.0  # (wedge) their lag-1 autocorrelation: the share of the model's error in them


def _score(pred: np.ndarray, meas: np.ndarray, keep: np.ndarray | None = None) -> tuple[float, float]:
    if keep is not None:
        pred, meas = pred[keep], meas[keep]
    res = pred - meas
    rms = math.sqrt(float((res ** 2).mean()))
    tot = float(((meas - meas.mean(0)) ** 2).sum())
    return rms, 1.0 - float((res ** 2).sum()) / max(tot, 1e-12)


def _used(data: ForceDataset) -> np.ndarray:
    from excavsim.learning.wedge_fit import touchdown_samples

    return ~touchdown_samples(data["z"], data["dig"])


PROFILE_PHI_DEG = np.arange(10.0, 45.01, 2.5)  # the profile of the cost over phi: the fit's bounds, 2.5 deg steps
# The range of phi a record supports: where the profile of the cost (c, delta, gamma fitted again at each
# phi) stays below a level above the best fit's (phi_interval) made of two allowances:
# * the noise's: the profile-likelihood interval at CONFIDENCE, chi2_1 s^2 tau (s^2 the residuals'
#   variance, tau their correlation's inflation within digs, wedge_fit.residual_inflation over
#   CORRELATION_WINDOW_S: the soil's strength varies over 0.3 m and the blade advances 0.1-0.15 m/s);
# * the model's: the map's depth error (3.6-7.5 mm RMS over ground already dug) slides the minimum along
#   the c-phi valley, a systematic error no noise level describes. Measured on 12 quiet records (3 soils x
#   seeds 0-3, 3 digs), the profile at the true phi is 0.1-9.5 % above its minimum (RMS), so the smooth
#   part of the residuals (their lag-1 autocorrelation's share of the variance: 0.3-0.95 in quiet records,
#   near 0 where the F/T's digging scatter dominates) is allowed a rise of PROFILE_RISE in RMS.
CONFIDENCE = 0.95
CORRELATION_WINDOW_S = 3.0
PROFILE_RISE = 0.10


def supported_range(values: np.ndarray, cost: np.ndarray, level: float) -> tuple[float, float]:
    """The interval of ``values`` (increasing) around the profile's minimum where ``cost`` stays at or
    below ``level``, its ends interpolated linearly between the grid's points (a grid end where the
    profile is still below the level)."""
    i = int(np.nanargmin(cost))
    lo, hi = i, i
    while lo > 0 and cost[lo - 1] <= level:
        lo -= 1
    while hi < len(values) - 1 and cost[hi + 1] <= level:
        hi += 1

    def cross(a: int, b: int) -> float:  # between inside a and outside b
        return float(values[a] + (level - cost[a]) / (cost[b] - cost[a]) * (values[b] - values[a]))

    left = cross(lo, lo - 1) if lo > 0 else float(values[0])
    right = cross(hi, hi + 1) if hi < len(values) - 1 else float(values[-1])
    return left, right


# The wedge's fitted parameters a calibration may hold (``--fix NAME=VALUE``): the name as printed (and
# the preset's name for it), the index into (c, phi, delta, gamma) and the factor from the printed
# unit to the fit's (Pa, rad, rad, N/m^3). The ranges are the fit's bounds (wedge_fit.WEDGE_BOUNDS).
WEDGE_FIX = {"c_pa": (0, 1.0), "phi_deg": (1, math.pi / 180.0), "delta_deg": (2, math.pi / 180.0),
             "gamma_n_m3": (3, 1.0)}
WEDGE_FIX_ALIASES = {"cohesion_pa": "c_pa", "friction_angle_deg": "phi_deg", "tool_friction_angle_deg": "delta_deg"}


def _dimaio_fix_ranges() -> dict[str, tuple[float, float]]:
    """DiMaio's parameters (Table 5.3's and ``S``) with the output-error fit's bounds."""
    ranges = {x: (0.0, math.inf) for x in identify.NAMES}
    ranges["T_rt"] = ranges["T_rn"] = (1e-3, 1e3)
    ranges["S"] = identify.LAG_BOUNDS["S"]
    return ranges


def fix_ranges(model: str) -> dict[str, tuple[float, float]]:
    """The names ``--fix`` takes for ``model`` and their allowed ranges (in the printed units)."""
    if model == "wedge":
        from excavsim.learning.wedge_fit import WEDGE_BOUNDS

        return {n: (WEDGE_BOUNDS[0][i] / f, WEDGE_BOUNDS[1][i] / f) for n, (i, f) in WEDGE_FIX.items()}
    return _dimaio_fix_ranges()


def parse_fixes(model: str, items: list[str] | None) -> dict[str, float]:
    """``NAME=VALUE`` strings (``--fix``) as ``{name: value}`` in the printed names and units of
    ``model``'s fit (for the wedge also the preset's names: cohesion_pa, friction_angle_deg,
    tool_friction_angle_deg).

    Raises:
        ExcavsimError: a malformed item, an unknown name, a value that is not a finite number in
            the name's range, a name given twice, or every parameter of the wedge held; the message
            names the allowed names and ranges.
    """
    ranges = fix_ranges(model)
    allowed = ", ".join(f"{n} in [{lo:g}, {hi:g}]" for n, (lo, hi) in ranges.items())
    if model == "wedge":
        allowed += " (or " + ", ".join(f"{a} for {n}" for a, n in WEDGE_FIX_ALIASES.items()) + ")"
    out: dict[str, float] = {}
    for item in items or []:
        name, eq, text = str(item).partition("=")
        name = name.strip()
        if not eq or not name:
            raise ConfigError(f"--fix {item!r}: give NAME=VALUE; for --model {model}: {allowed}")
        if model == "wedge":
            name = WEDGE_FIX_ALIASES.get(name, name)
        if name not in ranges:
            raise ConfigError(f"--fix {item!r}: {name!r} is not a parameter of the {model} fit; allowed: {allowed}")
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        lo, hi = ranges[name]
        if not (math.isfinite(value) and lo <= value <= hi):
            raise ConfigError(f"--fix {item!r}: {name} must be a number in [{lo:g}, {hi:g}]; allowed: {allowed}")
        if name in out:
            raise ConfigError(f"--fix {item!r}: {name} is held twice")
        out[name] = value
    if model == "wedge" and len(out) == len(WEDGE_FIX):
        raise ConfigError("--fix holds every parameter of the wedge (c_pa, phi_deg, delta_deg, gamma_n_m3): "
                          "nothing is left to fit; hold at most three")
    return out


def fit_wedge(data: ForceDataset, soil, width: float, *, starts: int = 4, seed: int = 0,
              profile: bool = True, fixed: dict[str, float] | None = None, brittleness: float = 0.0,
              rate_per_decade: float = 0.0, load_capacity_m3: float | None = None) -> Fit:
    """The wedge model's ``c, phi, delta, gamma`` fitted with bounds to a record
    (:class:`~excavsim.learning.wedge_fit.RecordWedge`, the touch-down samples left out), from
    ``soil`` and random starts; standard errors from the Jacobian, the estimates' correlation and,
    with ``profile``, the range of phi the record supports: the profile-likelihood interval at
    :data:`CONFIDENCE` (:func:`phi_interval`). A standard error of 1-2 deg hides that c and phi
    trade along a valley whose floor the map's depth error moves (corr(c, phi) -0.8 to -0.9 in the
    sands); the interval follows the valley.

    ``fixed``: parameters held (``{name: value}`` of :data:`WEDGE_FIX`, as :func:`parse_fixes` gives
    them), the rest fitted; the start takes their values, their standard error is 0 and, unless phi
    is held, the range of phi is that of the profile with them held. ``brittleness``: the failure
    cycle's ``I_B`` the record model averages over (0: eq. 8's crest; the default world's soil has
    0.2, ``truth.brittleness_index``). ``rate_per_decade``: the rate effect on cohesion the record
    model applies above 0.01 m/s (0: c is the strength at the digs' rate; the default world's clays
    have 0.1, ``truth.cohesion_rate_per_decade``). ``load_capacity_m3``: the heaped capacity with
    which the load bears on the wedge (the world's ``scene.bucket.load_surcharge``; None: the
    default world's bucket, ``inf``: no load surcharge)."""
    from excavsim.learning.wedge_fit import RecordWedge, advance_speed, residual_autocorrelation, residual_inflation

    held = {WEDGE_FIX[WEDGE_FIX_ALIASES.get(n, n)][0]: v * WEDGE_FIX[WEDGE_FIX_ALIASES.get(n, n)][1]
            for n, v in (fixed or {}).items()}

    cap = _heaped_capacity() if load_capacity_m3 is None else load_capacity_m3
    rw = RecordWedge(width, brittleness=brittleness, rate_per_decade=rate_per_decade, load_capacity_m3=cap)
    x = rw.inputs(data.samples, _loads(data, width), advance_speed(data["x"], data["t"], data["dig"]))
    keep = _used(data)
    start = np.array([soil.cohesion_pa, soil.phi, soil.delta, soil.density_kg_m3 * identify.G_M_S2])
    for i, v in held.items():
        start[i] = v
    theta, se, rms_fit = rw.fit(x[keep], data.forces[keep], start, starts=starts, seed=seed, fixed=held)
    pred = rw.forces(theta, x)
    rms, r2 = _score(pred, data.forces, keep)
    corr = rw.correlation(theta, x[keep])
    window = max(1, int(round(CORRELATION_WINDOW_S / _sample_period(data))))
    res, dig = pred[keep] - data.forces[keep], np.asarray(data["dig"])[keep]
    tau = residual_inflation(res, dig, window)
    smooth = float(np.clip(residual_autocorrelation(res, dig, 1)[1], 0.0, 1.0))
    phi_range = None
    if profile and 1 not in held:
        # the grid and the fit's own phi, so that the profile's minimum is the fit's
        values = np.unique(np.append(PROFILE_PHI_DEG, math.degrees(theta[1])))
        prof, _ = rw.profile(x[keep], data.forces[keep], theta, np.radians(values), fixed=held)
        phi_range = phi_interval(prof, rms_fit, data.forces[keep].size, 4 - len(held), tau, smooth, values=values)
    c, phi, delta, gamma = theta
    params = {"c_pa": float(c), "phi_deg": math.degrees(phi), "delta_deg": math.degrees(delta),
              "gamma_n_m3": float(gamma)}
    errors = {"c_pa": float(se[0]), "phi_deg": math.degrees(se[1]), "delta_deg": math.degrees(se[2]),
              "gamma_n_m3": float(se[3])}
    return Fit("wedge", params, errors, pred, rms, r2, corr, phi_range, fixed=dict(fixed or {}),
               brittleness=float(brittleness), rate_per_decade=float(rate_per_decade), inflation=tau,
               smooth_share=smooth)


def _heaped_capacity() -> float:
    """The default world's heaped bucket capacity, with which its load bears on the wedge [m^3]
    (``inf`` if the default scene has the load surcharge off)."""
    from excavsim import constants
    from excavsim.config import load_scene_config
    from excavsim.world.simulation import Simulation

    scene = load_scene_config()
    if not scene.bucket.load_surcharge:
        return math.inf
    struck = float(Simulation(seed=0).model.numeric(constants.BUCKET_CAPACITY_NUMERIC).data[0])
    return struck * scene.bucket.heaped_capacity_factor


def _sample_period(data: ForceDataset) -> float:
    """The record's F/T sample period [s] (the median step within a dig; 0.1 s if it has none)."""
    same = np.diff(np.asarray(data["dig"])) == 0
    return float(np.median(np.diff(np.asarray(data["t"], dtype=float))[same])) if same.any() else 0.1


def phi_interval(profile_rms: np.ndarray, rms_fit: float, n: int, n_params: int, tau: float, smooth: float, *,
                 values: np.ndarray = PROFILE_PHI_DEG, confidence: float = CONFIDENCE,
                 rise: float = PROFILE_RISE) -> tuple[float, float]:
    """The range of phi a record supports [deg]: the values (``values``, increasing, the profile's
    grid) at which the profile's sum of squares ``n rms^2`` exceeds the best fit's ``S_min`` by at most

        chi2_1(confidence) s^2 tau  +  ((1 + rise)^2 - 1) smooth S_min

    the first the likelihood-ratio test of phi (Wilks' theorem for Gaussian residuals; correlated
    ones count ``tau`` times less), ``s^2 = n rms_fit^2 / (n - n_params)``; the second the model's
    systematic error, the share ``smooth`` of the residuals' variance that is correlated from one
    sample to the next (their lag-1 autocorrelation), allowed to rise by ``rise`` in RMS (see
    :data:`PROFILE_RISE`). ``n``: the residuals (samples times axes). White residuals give the
    likelihood-ratio interval; a quiet record's smooth ones, the 10 % rule it was measured with."""
    from scipy.stats import chi2

    ssr = np.asarray(profile_rms, dtype=float) ** 2 * n
    ssr_min = min(float(np.nanmin(ssr)), rms_fit ** 2 * n)
    s2 = rms_fit ** 2 * n / max(n - n_params, 1)
    level = (ssr_min + float(chi2.ppf(confidence, 1)) * s2 * max(tau, 1.0)
             + ((1.0 + rise) ** 2 - 1.0) * float(np.clip(smooth, 0.0, 1.0)) * ssr_min)
    return supported_range(np.asarray(values, dtype=float), ssr, level)


# What dig records identify of DiMaio's model, with the tolerance measured (README: 12 fits, 4 DiMaio-truth
# records of 3 digs of the testbed sand, from starts twice, half and at the truth; largest error in brackets).
# At a steady drag between shears the lagging centre's force tends to k T_rt v_t (eqs. 5.44, 5.46), a
# force per speed like b_t0 s_p v_t's: the product is identified, k and T_rt apart are not, and b_t0
# trades with it; b_n0 multiplies a normal speed a dragging blade hardly has.
DIMAIO_IDENTIFIED = {"rho": 0.10, "mu": 0.20, "eps": 0.35, "S": 0.30, "k*T_rt": 0.30}  # (7, 16, 30, 25, 26 %)


def fit_dimaio(data: ForceDataset, start: dict[str, float], *, s_bucket: float, width: float,
               factors: tuple[float, ...] = SEARCH_FACTORS, fixed: dict[str, float] | None = None) -> Fit:
    """DiMaio's eight parameters of Table 5.3 and the shear strength ``S`` (eq. 5.45) fitted to a
    record: a variable-projection search from ``start`` scaled by each of ``factors``
    (:func:`~excavsim.learning.identify.projected_fit`), then the output-error fit (eq. 5.55), the
    model stepped ``SUBSTEPS`` times per sample (the controller's rate); the record's runs are the
    digs, the touch-down samples left out. Of the nine, dig data identify those of
    :data:`DIMAIO_IDENTIFIED` (the rest trade against each other).

    ``fixed``: parameters held at these values in the output-error fit (their standard error 0);
    the variable-projection search that gives its start does not hold them (it solves the five
    linear parameters jointly), its values of them are replaced by the held ones."""
    fixed = dict(fixed or {})
    rec = planar_record(data, s_bucket, width)
    keep = _used(data).astype(float)
    shear = (width, s_bucket)
    first = identify.projected_fit(rec, dict(start, **fixed), v_eps=V_EPS, substeps=SUBSTEPS, shear=shear,
                                   weights=keep, factors=factors)
    first.update(fixed)
    params, errors, _ = identify.output_error_fit(rec, first, v_eps=V_EPS, substeps=SUBSTEPS, shear=shear,
                                                  weights=keep, fixed=fixed)
    pred = identify.simulate(params, rec, v_eps=V_EPS, substeps=SUBSTEPS, shear=shear)
    rms, r2 = _score(pred, data.forces, keep > 0)
    return Fit("dimaio", params, errors, pred, rms, r2, fixed=fixed)


def dimaio_start(soil) -> dict[str, float]:
    """The preset's DiMaio values as the fit's start (Table 5.3's, and no shear, when it has none)."""
    dm = soil.dimaio
    if dm is None:
        return dict(TABLE_5_3, S=1e9)
    return {"b_t0": dm.viscous_tangential_n_s_m2, "b_n0": dm.viscous_normal_n_s_m2, "mu": dm.friction_coefficient,
            "eps": dm.accumulation_n_m3, "rho": soil.density_kg_m3, "k": dm.stiffness_n_m,
            "T_rt": dm.relax_tangential_s, "T_rn": dm.relax_normal_s, "S": dm.shear_strength_pa}


def fitted_soil(fit: Fit, soil):
    """``soil`` (a :class:`~excavsim.config.SoilParams`) with the fit's parameters."""
    from excavsim.config import SoilParams

    body = soil.model_dump(exclude_none=True)
    p = fit.params
    if fit.model == "wedge":
        body.update(density_kg_m3=p["gamma_n_m3"] / identify.G_M_S2, friction_angle_deg=p["phi_deg"],
                    tool_friction_angle_deg=p["delta_deg"], cohesion_pa=p["c_pa"])
    else:
        dm = dict(body.get("dimaio") or {})
        dm.update(viscous_tangential_n_s_m2=p["b_t0"], viscous_normal_n_s_m2=p["b_n0"], friction_coefficient=p["mu"],
                  accumulation_n_m3=p["eps"], stiffness_n_m=p["k"], relax_tangential_s=p["T_rt"],
                  relax_normal_s=p["T_rn"], shear_strength_pa=p.get("S", 1e9))
        body["dimaio"] = dm
        body["density_kg_m3"] = p["rho"]
    return SoilParams.model_validate(body)


def preset_yaml(fit: Fit, soil, name: str, source: str) -> str:
    """A soil preset (configs/soils.yaml's form) with the fitted parameters; the rest from ``soil``."""
    import yaml

    from excavsim.config import SoilsFile

    body = fitted_soil(fit, soil).model_dump(exclude_none=True)
    for k in ("density_kg_m3", "friction_angle_deg", "tool_friction_angle_deg", "cohesion_pa"):
        body[k] = round(float(body[k]), 3)
    if body.get("dimaio"):
        body["dimaio"] = {k: float(round(v, 6)) for k, v in body["dimaio"].items()}
    body["description"] = f"fitted by excavsim calibrate --model {fit.model} to {source}"
    SoilsFile.model_validate({"soils": {name: body}})  # the file must load
    return yaml.safe_dump({"soils": {name: body}}, sort_keys=False)


