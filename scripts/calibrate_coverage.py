"""How well ``excavsim calibrate --model wedge`` recovers known soils, over many records (issue 22).

For each soil and seed: a record of ``--digs`` random feasible digs in a fresh box (``excavsim
calibrate --record-digs``), quiet (``--quiet``: the wedge's rate effect, failure-cycle drops,
heterogeneity and the F/T's digging disturbance off, so that the soil is exactly the preset) or with
the world's full variability (the default). Each record is fitted as ``excavsim calibrate`` fits it
(the touch-down samples left out, the scans' load), free and, for soils with c < 5 kPa, with c held
at its truth (``--fix c_pa=...``; for the others gamma, their density), with the failure cycle's
``--brittleness`` in the record model. Printed per record: the errors of c, phi, delta and gamma,
the range of phi the record supports (the profile-likelihood interval,
``loop/calibrate.phi_interval``) and whether it holds the true phi, and the force error (the RMS
difference of the record model's forces along the record with the fitted and with the true soil,
over the true soil's RMS force: the force is identified even where its split into c and phi is not),
and, from the world (the truth, which the fit never sees), the mean strength factor of the soil's
heterogeneity under the record's cuts (``truth.heterogeneity_std``: 1 is the preset; the record
measures the soil it dug). Then per soil and fit, the counts within the stated tolerances, and the
correlations of the phi and c errors with that strength factor, and the force error against the dug
soil (the preset's blade force times that factor, the load's weight unchanged).

Usage::

    python scripts/calibrate_coverage.py [--soils testbed_sand,sandy_loam,lean_clay] [--seeds 0-7]
        [--digs 3] [--quiet] [--brittleness 0.2] [--rate-effect 0.1] [--records DIR]

``--records DIR`` keeps the records there and reuses those already made (named
``SOIL_sSEED_dDIGS[_quiet].npz``). About 3 s per record of 3 digs and 10 s per fit here.
"""

from __future__ import annotations

import argparse
import math
import pathlib
import sys
import tempfile

import numpy as np


def _seeds(text: str) -> list[int]:
    if "-" in text:
        a, b = text.split("-")
        return list(range(int(a), int(b) + 1))
    return [int(s) for s in text.split(",")]


def _corr(a, b) -> float:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return float(np.corrcoef(a, b)[0, 1]) if a.size > 2 and a.std() > 0 and b.std() > 0 else float("nan")


def _strength_under_cuts(data, soil: str, seed: int) -> float:
    """The world's strength factor (the heterogeneity field of the record's seed) averaged over the
    cells under the record's tip path (the arm's plane at the straight goal's waist, the bucket's
    width across it): what the record's soil is, against the preset's 1. Truth, for this
    diagnosis only."""
    from excavsim.loop.scenario import EpisodeSpec, ResolvedSpec
    from excavsim.robot.extract import arm_from_model
    from excavsim.world.simulation import Simulation

    cfg = ResolvedSpec(EpisodeSpec(name="calibrate", goal="straight", soil=soil, seed=seed))
    sim = Simulation(cfg.robot, cfg.scene, seed=seed)
    arm = arm_from_model(sim.model)
    waist = math.radians(cfg.goal.waist_deg)
    half = 0.5 * float(data.meta.get("bucket_width_m", 0.3))
    xz = np.stack([np.asarray(data["x"], dtype=float), np.asarray(data["z"], dtype=float)], axis=-1)
    path = arm.plane_to_world(waist, xz)[:, :2]
    o, e1 = arm.plane_to_world(waist, np.array([[0.0, 0.0], [1.0, 0.0]]))[:, :2]  # the plane's direction
    along = (e1 - o) / np.linalg.norm(e1 - o)
    normal = np.array([-along[1], along[0]])
    pts = (path[None, :, :] + np.linspace(-half, half, 5)[:, None, None] * normal).reshape(-1, 2)
    g, st = sim.soil.grid, sim.soil.strength
    ix = np.clip(((pts[:, 0] - g.x0) / g.cell).round().astype(int), 0, st.shape[1] - 1)
    iy = np.clip(((pts[:, 1] - g.y0) / g.cell).round().astype(int), 0, st.shape[0] - 1)
    return float(st[iy, ix].mean())  # rows are y, columns x (world.grid_kernels.bilinear)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--soils", default="testbed_sand,sandy_loam,lean_clay")
    ap.add_argument("--seeds", default="0-7", type=_seeds)
    ap.add_argument("--digs", type=int, default=3, help="digs per record (>= 1)")
    ap.add_argument("--quiet", action="store_true")
    ap.add_argument("--brittleness", type=float, default=None,
                    help="I_B of the record model (default: 0 for --quiet, 0.2, the scene's, otherwise)")
    ap.add_argument("--rate-effect", type=float, default=None,
                    help="the record model's rate effect on cohesion per decade (default 0: c at the digs' rate; "
                         "the scene's is 0.1)")
    ap.add_argument("--records", metavar="DIR", help="where the records are kept (default: a temporary directory)")
    args = ap.parse_args(argv)
    if args.digs < 1:
        ap.error(f"--digs must be at least 1; given {args.digs}")
    if args.brittleness is not None and not 0.0 <= args.brittleness < 1.0:
        ap.error(f"--brittleness must be in [0, 1); given {args.brittleness}")
    if args.rate_effect is not None and not 0.0 <= args.rate_effect <= 1.0:
        ap.error(f"--rate-effect must be in [0, 1]; given {args.rate_effect}")

    from excavsim.config import get_soil
    from excavsim.learning import identify
    from excavsim.learning.wedge_fit import RecordWedge, advance_speed
    from excavsim.apps.calibrate import fit as cal
    from excavsim.apps.calibrate import run as calrun
    from excavsim.apps.calibrate.digs import record_digs

    ib = args.brittleness if args.brittleness is not None else (0.0 if args.quiet else 0.2)
    rate = args.rate_effect if args.rate_effect is not None else 0.0
    where = pathlib.Path(args.records) if args.records else pathlib.Path(tempfile.mkdtemp(prefix="calcov-"))
    where.mkdir(parents=True, exist_ok=True)
    print(f"records of {args.digs} digs, {'quiet' if args.quiet else 'the world full variability'}; the record model's "
          f"brittleness {ib:g}, rate effect {rate:g}; records in {where}", flush=True)
    head = (f"{'soil':13s} {'seed':>4s} {'fit':6s} {'c kPa':>6s} {'dphi':>6s} {'ddelta':>6s} {'dgamma':>6s} "
            f"{'phi range':>11s} {'in':>3s} {'tau':>5s} {'force err':>9s} {'strength':>8s} {'vs dug':>7s}")
    print(head)
    rows = []
    for soil_name in args.soils.split(","):
        soil = get_soil(soil_name)
        truth = np.array([soil.cohesion_pa, soil.phi, soil.delta, soil.density_kg_m3 * identify.G_M_S2])
        tphi = math.degrees(soil.phi)
        for seed in args.seeds:
            path = where / f"{soil_name}_s{seed}_d{args.digs}{'_quiet' if args.quiet else ''}.npz"
            if path.exists():
                from excavsim.learning.dataset import ForceDataset

                data = ForceDataset.load(path)
            else:
                data = record_digs(path, soil=soil_name, digs=args.digs, seed=seed, quiet=args.quiet)
            width = float(data.meta.get("bucket_width_m", 0.0)) or calrun._bucket_width()
            keep = cal._used(data)
            rw = RecordWedge(width, brittleness=ib, rate_per_decade=rate)
            x = rw.inputs(data.samples, cal._loads(data, width), advance_speed(data["x"], data["t"], data["dig"]))
            f_true = rw.forces(truth, x[keep])
            local = _strength_under_cuts(data, soil_name, seed)
            rho, vol = x[keep, 5], np.maximum(x[keep, 6], 0.0)
            load = truth[3] * vol[:, None] * np.stack([np.sin(rho), -np.cos(rho)], axis=-1)
            f_dug = load + local * (f_true - load)  # the preset's blade force times the dug soil's strength
            fits = {"free": None}
            if soil.cohesion_pa < 5000.0:
                fits["c held"] = {"c_pa": soil.cohesion_pa}
            else:  # a clay: its density is what a soil engineer knows (a weighed sample)
                fits["gamma held"] = {"gamma_n_m3": float(truth[3])}
            for label, fixed in fits.items():
                fit = cal.fit_wedge(data, soil, width, fixed=fixed, brittleness=ib, rate_per_decade=rate)
                p = fit.params
                th = np.array([p["c_pa"], math.radians(p["phi_deg"]), math.radians(p["delta_deg"]), p["gamma_n_m3"]])
                f_fit = rw.forces(th, x[keep])
                ferr = math.sqrt(((f_fit - f_true) ** 2).sum(1).mean() / (f_true ** 2).sum(1).mean())
                ferr_dug = math.sqrt(((f_fit - f_dug) ** 2).sum(1).mean() / (f_dug ** 2).sum(1).mean())
                lo, hi = fit.phi_range_deg
                row = dict(soil=soil_name, seed=seed, fit=label, c=p["c_pa"] / 1e3, dphi=p["phi_deg"] - tphi,
                           ddelta=p["delta_deg"] - math.degrees(soil.delta), dgamma=p["gamma_n_m3"] / truth[3] - 1,
                           lo=lo, hi=hi, inside=lo <= tphi <= hi, tau=fit.inflation, ferr=ferr,
                           dc=p["c_pa"] - soil.cohesion_pa, strength=local, ferr_dug=ferr_dug)
                rows.append(row)
                print(f"{soil_name:13s} {seed:4d} {label[:6]:6s} {row['c']:6.2f} {row['dphi']:+6.1f} "
                      f"{row['ddelta']:+6.1f} {row['dgamma'] * 100:+5.1f}% {lo:5.1f}-{hi:4.1f} "
                      f"{'yes' if row['inside'] else 'no':>3s} {fit.inflation:5.1f} {ferr * 100:8.1f}% {local:8.3f} "
                      f"{ferr_dug * 100:6.1f}%",
                      flush=True)
    print()
    print(f"{'soil':13s} {'fit':10s} {'records':>7s} {'phi 3 deg':>9s} {'phi 5 deg':>9s} {'in range':>8s} "
          f"{'range width':>11s} {'delta 3.5':>9s} {'gamma 10%':>9s} {'c 1 kPa/10%':>11s} {'force err':>13s} "
          f"{'corr(dphi, strength)':>20s} {'corr(dc, strength)':>18s} {'force err vs dug soil':>21s}")
    for soil_name in args.soils.split(","):
        c_true = get_soil(soil_name).cohesion_pa
        for label in ("free", "c held", "gamma held"):
            sel = [r for r in rows if r["soil"] == soil_name and r["fit"] == label]
            if not sel:
                continue
            n = len(sel)

            def count(pred) -> str:
                return f"{sum(1 for r in sel if pred(r))}/{n}"

            widths = np.array([r["hi"] - r["lo"] for r in sel])
            ferr = np.array([r["ferr"] for r in sel])
            print(f"{soil_name:13s} {label:10s} {n:7d} {count(lambda r: abs(r['dphi']) < 3):>9s} "
                  f"{count(lambda r: abs(r['dphi']) < 5):>9s} {count(lambda r: r['inside']):>8s} "
                  f"{np.median(widths):8.1f} deg {count(lambda r: abs(r['ddelta']) < 3.5):>9s} "
                  f"{count(lambda r: abs(r['dgamma']) < 0.10):>9s} "
                  f"{count(lambda r: abs(r['dc']) < max(1000.0, 0.1 * c_true)):>11s} "
                  f"{ferr.min() * 100:4.1f}-{ferr.max() * 100:4.1f} % "
                  f"{_corr([r['dphi'] for r in sel], [r['strength'] for r in sel]):+20.2f} "
                  f"{_corr([r['dc'] for r in sel], [r['strength'] for r in sel]):+18.2f} "
                  f"{min(r['ferr_dug'] for r in sel) * 100:14.1f}-{max(r['ferr_dug'] for r in sel) * 100:4.1f} %")
    return 0


if __name__ == "__main__":
    from excavsim.errors import ExcavsimError

    try:
        sys.exit(main())
    except ExcavsimError as exc:  # an unknown soil, a record that cannot be made
        print(f"calibrate_coverage: {exc}", file=sys.stderr)
        sys.exit(2)
