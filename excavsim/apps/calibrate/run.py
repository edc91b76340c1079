"""A soil's calibration from a force record: ``excavsim calibrate`` (DiMaio 1998 §5.5, Singh 1995 eq. 8).

:func:`calibrate` fits a soil to a record of digs (:mod:`~excavsim.apps.calibrate.fit`: the model
asked for and, for the cross-model report, the other), prints the parameters with standard errors,
writes a soil preset YAML, re-runs the recorded digs in MuJoCo with the fitted soil of each model
(:func:`rerun`, :func:`~excavsim.apps.calibrate.digs.rerun_digs`) and plots, per dig, measured,
fitted and re-run forces; the report says how well each model (fitted to the same record:
cross-model) and each re-run explains the record. :func:`calibrate_file` is the command: a force
data set file or a Rerun recording, recorded first when asked.
"""

from __future__ import annotations

import dataclasses
import math
import pathlib
from collections.abc import Callable

import numpy as np

from excavsim.apps.calibrate.fit import (CONFIDENCE, DIMAIO_IDENTIFIED, PROFILE_RISE, Fit, _score, _used,
                                         dimaio_start, fit_dimaio, fit_wedge, fitted_soil, parse_fixes,
                                         preset_yaml)
from excavsim.errors import ConfigError, DataFileError, UsageError
from excavsim.learning.dataset import ForceDataset

RERUN_LAG_S = 1.5  # the re-run of a dig is aligned with the record within this lag [s]


@dataclasses.dataclass
class Rerun:
    """The recorded digs dug again in the world with a fitted soil: forces at the record's samples."""

    model: str
    forces: np.ndarray  # (n, 2) the re-run's tip-frame forces at the record's times since each dig's start [N]
    rms_n: float
    r2: float


def rerun(data: ForceDataset, fit: Fit, soil, *, say: Callable[[str], None] | None = None) -> Rerun:
    """Dig the record's actions again in MuJoCo with the fitted soil on the fitted model's truth
    (:func:`~excavsim.apps.calibrate.digs.rerun_digs`) and compare, dig by dig, the re-run's forces
    with the measured ones at the same time since the dig's first sample, up to a common lag
    (:func:`_aligned`)."""
    from excavsim.apps.calibrate.digs import rerun_digs

    quiet = data.meta.get("quiet", "true") == "true"
    again = rerun_digs(data, fitted_soil(fit, soil), truth=fit.model, quiet=quiet, seed=int(data.meta.get("seed", 0)),
                       say=say)
    out = np.full((len(data), 2), np.nan)
    for k in np.unique(data["dig"]):
        m = data["dig"] == k
        a = again["dig"] == k
        if a.sum() < 2:
            continue
        out[m] = _aligned(data["t"][m] - data["t"][m][0], data.forces[m], again["t"][a] - again["t"][a][0],
                          again.forces[a])
    ok = np.isfinite(out).all(1) & _used(data)
    rms, r2 = _score(np.nan_to_num(out), data.forces, ok) if ok.any() else (math.nan, math.nan)
    return Rerun(fit.model, out, rms, r2)


def _aligned(t: np.ndarray, f: np.ndarray, t_again: np.ndarray, f_again: np.ndarray) -> np.ndarray:
    """The re-run's forces (n, 2) at the record's times ``t`` (n,), shifted in time by the lag within
    ``RERUN_LAG_S`` that fits the record best (a fitted lag, 0.02 s steps): a dig's samples start at
    the touch-down's contact, which the two runs need not reach at the same time after the dig's
    start, and a recording's dig window is found from the joint angles at 10 Hz."""
    best, best_cost = None, math.inf
    for lag in np.arange(-RERUN_LAG_S, RERUN_LAG_S + 1e-9, 0.02):
        g = np.stack([np.interp(t + lag, t_again, f_again[:, j], left=np.nan, right=np.nan) for j in (0, 1)], -1)
        ok = np.isfinite(g).all(1)
        if ok.sum() < 0.8 * len(t):
            continue
        cost = float(((g[ok] - f[ok]) ** 2).mean())
        if cost < best_cost:
            best, best_cost = g, cost
    return best if best is not None else np.full_like(f, np.nan)


def calibrate(record: str | pathlib.Path | ForceDataset, model: str, out: str | pathlib.Path, *,
              soil: str | None = None, rerun_digs: bool = True, cross_model: bool = True,
              name: str | None = None, fixed: dict[str, float] | None = None, brittleness: float = 0.0,
              rate_per_decade: float = 0.0, say: Callable[[str], None] = print) -> dict[str, Fit]:
    """Fit the ``model`` soil (and, for the cross-model report, the other) to a record; write the
    preset YAML and the predicted-against-measured plot to ``out``; with ``rerun_digs``, dig the
    recorded digs again in simulation with the fitted soil of each model (PNG per dig). Returns the
    fits by model (only ``model``'s without ``cross_model``).

    ``record``: a force data set file (.npz, .parquet, .csv) or a :class:`ForceDataset` (a Rerun
    recording read by the CLI, :func:`~excavsim.apps.calibrate.digs.dataset_from_recording`).
    ``fixed``: ``model``'s parameters held at given values (``{name: value}``, :func:`parse_fixes`;
    the other model of the cross-model report is fitted free). ``brittleness``: the failure
    cycle's ``I_B`` the wedge's record model averages over (:class:`~excavsim.learning.wedge_fit.RecordWedge`;
    0, eq. 8's crest, for a quiet record; the default world's 0.2 for a record of it).
    ``rate_per_decade``: the rate effect on cohesion the wedge's record model applies (0, or the
    default world's 0.1 for a clay: the fitted c is then the strength at 0.01 m/s, as the presets').

    Raises:
        ExcavsimError: the record cannot be read, has too few samples, the model is unknown, a
            held parameter is not one of the model's (:func:`parse_fixes`), ``brittleness`` is
            not in [0, 1) or ``rate_per_decade`` not in [0, 1].
    """
    from excavsim.config import get_soil, load_scene_config

    if model not in ("wedge", "dimaio"):
        raise ConfigError(f"unknown model {model!r}; allowed: wedge, dimaio")
    fixed = parse_fixes(model, [f"{k}={v!r}" for k, v in (fixed or {}).items()])
    if not (isinstance(brittleness, (int, float)) and 0.0 <= brittleness < 1.0):
        raise ConfigError(f"brittleness must be a number in [0, 1) (the share of the failure force lost at "
                          f"each failure; 0: eq. 8's crest); given {brittleness!r}")
    if not (isinstance(rate_per_decade, (int, float)) and 0.0 <= rate_per_decade <= 1.0):
        raise ConfigError(f"rate_per_decade must be a number in [0, 1] (the cohesion's rise per tenfold digging "
                          f"speed; 0: none); given {rate_per_decade!r}")
    if isinstance(record, ForceDataset):
        data, label = record, name or "recording"
    else:
        record = pathlib.Path(record)
        if record.suffix == ".rrd":
            raise UsageError(f"{record}: a Rerun recording is read by the command line (`excavsim calibrate "
                             f"{record.name}`), or pass the data set excavsim.apps.calibrate.digs."
                             "dataset_from_recording made of it")
        data, label = ForceDataset.load(record), name or record.stem
    if len(data) < 10:
        raise DataFileError(f"{label}: {len(data)} samples; calibrating needs at least 10")
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    base = get_soil(soil or data.meta.get("soil") if (soil or data.meta.get("soil", "unknown") != "unknown")
                    else load_scene_config().soil)
    width = float(data.meta.get("bucket_width_m", 0.0)) or _bucket_width()
    s_bucket = base.dimaio.cutting_surface_m if base.dimaio is not None else 0.3
    fits = {}
    if model == "wedge" or cross_model:
        fits["wedge"] = fit_wedge(data, base, width, fixed=fixed if model == "wedge" else None,
                                  brittleness=brittleness, rate_per_decade=rate_per_decade)
    if model == "dimaio" or cross_model:
        fits["dimaio"] = fit_dimaio(data, dimaio_start(base), s_bucket=s_bucket, width=width,
                                    fixed=fixed if model == "dimaio" else None)
    fit = fits[model]
    truth = data.meta.get("truth", "unknown")
    measured = "the scans' removed volume" if data.meta.get("removed_m3", "{}") != "{}" else "the swept volume"
    say(f"{label}: {len(data)} samples of {data.n_digs} digs (truth: {truth}; the load from {measured}); "
        f"fitted {model}:")
    for p, v in fit.params.items():
        say(f"  {p:12s} {v:14.6g} " + ("(held)" if p in fit.fixed else f"+- {fit.errors[p]:.3g}"))
    if fit.phi_range_deg is not None:
        lo, hi = fit.phi_range_deg
        held = ", ".join(f"{k} {v:g}" for k, v in fit.fixed.items())
        say(f"  the record supports phi {lo:.0f}-{hi:.0f} deg (the {CONFIDENCE:.0%} profile-likelihood interval, the "
            f"residuals' correlation inflating it {fit.inflation:.1f} times, and {PROFILE_RISE:.0%} in RMS for the "
            f"{fit.smooth_share:.0%} of their variance that is smooth, the model's error"
            + (f", {held} held)" if held else f"); correlation of c and phi {fit.correlation[0, 1]:+.2f}"))
    if fit.model == "wedge":
        say(f"  failure cycle: the blade force averaged over drops of {fit.brittleness:g} of eq. 8's crest"
            + (" (none: eq. 8 itself, as in a quiet record)" if fit.brittleness == 0 else ""))
        say("  rate effect: " + (f"cohesion {fit.rate_per_decade:g} higher per tenfold advance speed above 0.01 m/s "
                                 "(c is the strength at 0.01 m/s)" if fit.rate_per_decade > 0
                                 else "none (c is the strength at the digs' rate)"))
        if data.meta.get("quiet") == "false" and fit.brittleness == 0:
            say("  note: the record was made with the world's truth terms on (not --quiet): its failure cycle's "
                "drops lower the mean force below eq. 8's crest; --brittleness 0.2 (the default world's) models them")
    if fit.model == "dimaio":
        say(f"  identified by dig data: rho, mu, eps, S and k*T_rt = {fit.params['k'] * fit.params['T_rt']:.4g} N s/m "
            "(within " + ", ".join(f"{k} {v:.0%}" for k, v in DIMAIO_IDENTIFIED.items())
            + " on DiMaio-truth records); k, T_rt, T_rn, b_t0 and b_n0 apart are not")
    reruns: dict[str, Rerun] = {}
    one_episode = data.meta.get("source") == "excavsim.apps.calibrate.digs"
    if rerun_digs and not one_episode:
        say("  (no re-run: the record is not the digs of one episode, as --record-digs or a recording gives)")
    if rerun_digs and one_episode:
        for m, f in fits.items():
            reruns[m] = rerun(data, f, base)
    say("how well each model explains the record (each fitted to it; the touch-down samples left out):")
    for m, f in fits.items():
        line = f"  {m:7s} fitted model: RMS {f.rms_n:7.1f} N, R^2 {f.r2:6.3f}"
        if m in reruns:
            line += f"; re-run in MuJoCo with its fitted soil: RMS {reruns[m].rms_n:7.1f} N, R^2 {reruns[m].r2:6.3f}"
        say(line)
    stem = label.replace(" ", "_")
    yaml_path = out / f"{stem}_{model}.yaml"
    yaml_path.write_text(preset_yaml(fit, base, f"{stem}_{model}".replace("-", "_"), label))
    png = out / f"{stem}_{model}.png"
    _plot_fit(png, data, fits, reruns, model)
    say(f"wrote {yaml_path} and {png}")
    return fits


def _bucket_width() -> float:
    from excavsim import constants
    from excavsim.world.simulation import Simulation

    return float(Simulation(seed=0).model.numeric(constants.BUCKET_WIDTH_NUMERIC).data[0])


def _plot_fit(path: pathlib.Path, data: ForceDataset, fits: dict[str, Fit], reruns: dict[str, Rerun],
              model: str, *, columns: int = 4) -> None:
    """Per dig (``columns`` digs a row, each over two panels: f_x above f_z): measured, each fitted
    model, each re-run."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    digs = np.unique(data["dig"])
    cols = min(len(digs), columns)
    rows = -(-len(digs) // cols)
    fig, axes = plt.subplots(2 * rows, cols, figsize=(4.5 * cols + 1, 5.8 * rows + 0.6), squeeze=False)
    colours = {"wedge": "tab:orange", "dimaio": "tab:blue"}
    for i, k in enumerate(digs):
        m = data["dig"] == k
        t = data["t"][m] - data["t"][m][0]
        for r, label in enumerate(("f_x (along the blade)", "f_z (blade normal)")):
            ax = axes[2 * (i // cols) + r, i % cols]
            ax.plot(t, data.forces[m, r], "k.", ms=3, label="measured")
            for name, f in fits.items():
                ax.plot(t, f.predicted[m, r], color=colours[name], lw=1.6 if name == model else 0.9,
                        label=f"{name} fitted (R^2 {f.r2:.2f})")
            for name, rr in reruns.items():
                ax.plot(t, rr.forces[m, r], color=colours[name], ls="--", lw=1.0,
                        label=f"{name} re-run in MuJoCo (R^2 {rr.r2:.2f})")
            if i % cols == 0:
                ax.set_ylabel(f"{label} [N]")
            if r == 1:
                ax.set_xlabel(f"dig {int(k) + 1}: time since its first sample [s]")
    for j in range(len(digs), rows * cols):
        for r in (0, 1):
            axes[2 * (j // cols) + r, j % cols].set_visible(False)
    axes[0, 0].legend(loc="best", fontsize=7)
    fig.suptitle(f"calibrate --model {model}: measured, fitted and re-run tip-frame forces per dig")
    fig.tight_layout()
    fig.savefig(path, dpi=min(90.0, 1000.0 / fig.get_figwidth()))  # at most 1000 px wide
    plt.close(fig)


def calibrate_file(record: str | pathlib.Path, model: str, out: str | pathlib.Path, *, soil: str | None = None,
                   rerun_digs: bool = True, fixed: dict[str, float] | None = None, brittleness: float = 0.0,
                   rate_per_decade: float = 0.0, record_digs_n: int | None = None, truth: str = "wedge",
                   seed: int = 0, quiet: bool = False, rrd: str | None = None,
                   say: Callable[[str], None] = print) -> dict[str, Fit]:
    """``excavsim calibrate RECORD``: :func:`calibrate` on a force data set file or on a Rerun
    recording (``.rrd``: its F/T, joint angles, scans and plans are read), first digging
    ``record_digs_n`` random feasible digs into ``record`` when asked.

    Args:
        record: the force data set (.npz, .parquet, .csv) or Rerun recording (.rrd).
        record_digs_n: dig this many digs on the ``truth`` world first (seeded by ``seed``; ``quiet``:
            its rate effect, failure-cycle drops, heterogeneity and the F/T's disturbance off) and save
            their record as ``record``; ``rrd``: also record that episode to this Rerun file.
        The rest: as :func:`calibrate`.
    """
    record = pathlib.Path(record)
    if record_digs_n:
        from excavsim.apps.calibrate.digs import record_digs

        say(f"excavsim calibrate: recording {record_digs_n} digs on the {truth} truth into {record}"
            + (f" (and the episode into {rrd})" if rrd else ""))
        observer = None
        if rrd:
            from excavsim.record import TrenchRecorder

            observer = TrenchRecorder(rrd)
        record_digs(record, truth=truth, soil=soil, digs=record_digs_n, seed=seed, quiet=quiet, observer=observer,
                    say=say)
    options = dict(soil=soil, rerun_digs=rerun_digs, fixed=fixed, brittleness=brittleness,
                   rate_per_decade=rate_per_decade, say=say)
    if record.suffix == ".rrd":
        from excavsim.apps.calibrate.digs import recording_dataset
        from excavsim.record.reading import read_recording

        try:
            data = recording_dataset(read_recording(record))
        except DataFileError as exc:  # what the recording lacks, said with its name
            if str(exc).startswith(f"{record}:"):
                raise
            raise DataFileError(f"{record}: {exc}") from None
        return calibrate(data, model, out, name=record.stem, **options)
    return calibrate(record, model, out, **options)

