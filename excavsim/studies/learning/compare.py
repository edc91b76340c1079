"""The ``excavsim learn`` study: data, Tables 4 and 5, Fig. 81, and the nominal-versus-learned campaign.

:func:`run_learn` builds a force data set by digging in the simulator (or loads one), cross-validates
every method on every basis (Table 4, in the thesis' protocol of shuffled samples and holding out
whole digs), measures costs (Table 5), prints the global regression's weights (Table 2), draws
Fig. 81, writes the numbers to ``learn.json`` next to the data, and optionally compares the
nominal wedge model with learned predictors in closed-loop episodes.
"""

from __future__ import annotations

import dataclasses
import json
import math
import pathlib
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from excavsim.config import get_soil
from excavsim.errors import ConfigError
from excavsim.learning.bases import get_basis
from excavsim.learning.dataset import ForceDataset
from excavsim.learning.evaluate import (cross_validate, format_table4, format_table5, large_force_errors,
                                        measure_costs)
from excavsim.learning.figures import plot_large_force_errors
from excavsim.learning.predictors import METHODS, GlobalRegression
from excavsim.rig.online import DigLearning, OnlineLearning

SPLITS = {"digs": "whole digs held out", "samples": "shuffled samples (the thesis' protocol)"}  # primary first
FLATTERY = ("Shuffling samples flatters the memory-based methods: neighbouring samples of one dig, a centimetre "
            "or two apart, are near-duplicates, so a held-out sample has its twin in the training data. "
            "A planner predicts digs it has not made: whole digs held out is its situation.")


def default_format() -> str:
    """``.parquet`` when pyarrow is installed (rerun-sdk brings it), else ``.npz``."""
    try:
        import pyarrow.parquet  # noqa: F401
    except ImportError:
        return ".npz"
    return ".parquet"


def bucket_width(data: ForceDataset) -> float:
    """The bucket width the data were collected with [m] (from the data's metadata, else the model)."""
    if "bucket_width_m" in data.meta:
        return float(data.meta["bucket_width_m"])
    from excavsim import constants
    from excavsim.world.simulation import Simulation

    return float(Simulation().model.numeric(constants.BUCKET_WIDTH_NUMERIC).data[0])


def format_weights(model: GlobalRegression) -> str:
    """Table 2: the global regression's weights on the raw basis functions."""
    w = model.weights()
    labels = list(model.basis.labels) + ["1"]
    lines = [f"Table 2  Weights found by global regression ({model.basis.name} basis, eq. {model.basis.equation}; "
             f"units N per unit of each term)", "   " + "".join(f"{lab:>11}" for lab in labels)]
    for row, name in ((0, "x"), (1, "z")):
        lines.append(f"{name:<3}" + "".join(f" {v:>10.4g}" for v in w[:, row]))
    return "\n".join(lines)


def run_learn(*, soil: str | None = None, digs: int = 30, seed: int = 0, out: str | pathlib.Path = "runs/learn",
              dataset: str | pathlib.Path | None = None, folds: int = 10, split: str = "both", compare: bool = False,
              episodes: int = 2, dig_budget: int = 6, wrist_limit: float | None = None, method: str = "global",
              forgetting: float = 1.0, progress: Callable[[str], None] = print) -> dict[str, Any]:
    """Run the study (see the module docstring); prints as it goes and returns the numbers.

    Raises:
        ExcavsimError: a bad argument (the message names it and what is allowed).
    """
    say = progress
    if digs < 1:
        raise ConfigError(f"--digs must be at least 1; given {digs}")
    if folds < 2:
        raise ConfigError(f"--folds must be at least 2; given {folds}")
    if split not in (*SPLITS, "both"):
        raise ConfigError(f"--split must be one of {', '.join((*SPLITS, 'both'))}; given {split!r}")
    if not 0.0 < forgetting <= 1.0:
        raise ConfigError(f"--forgetting must lie in (0, 1]; given {forgetting}")
    if episodes < 1 or dig_budget < 1:
        raise ConfigError(f"--episodes and --dig-budget must be at least 1; given {episodes}, {dig_budget}")
    if method not in METHODS:
        raise ConfigError(f"--method must be one of {', '.join(METHODS)}; given {method!r}")
    if soil is not None:
        get_soil(soil)  # an unknown name fails here, listing the presets
    out = pathlib.Path(out)
    path = pathlib.Path(dataset) if dataset else out / f"dataset{default_format()}"
    if dataset and path.exists():
        data = ForceDataset.load(path)
        say(f"loaded {len(data)} samples of {data.n_digs} digs from {path}")
        if soil and data.meta.get("soil", soil) != soil:
            raise ConfigError(f"{path} holds data of soil {data.meta['soil']!r}, not {soil!r}: drop --soil or "
                              f"--dataset")
    else:
        from excavsim.studies.learning.collect import collect_dataset

        say(f"collecting force data: {digs} random feasible digs (seed {seed})")
        data = collect_dataset(soil=soil, digs=digs, seed=seed, progress=say)
        say(f"saved {len(data)} samples of {data.n_digs} digs to {data.save(path)}")
    if len(data) < 10 * folds:
        raise ConfigError(f"{len(data)} samples are too few for {folds}-fold cross-validation; collect more digs")
    soil_name = data.meta.get("soil") or soil or "testbed_sand"
    nominal = get_soil(soil_name)
    width = bucket_width(data)
    report: dict[str, Any] = {"dataset": str(path), "samples": len(data), "digs": data.n_digs, "soil": soil_name,
                            "folds": folds, "table4": {}, "table5": {}}
    splits = list(SPLITS) if split == "both" else [split]
    results = {}
    for s in splits:
        say(f"\n{folds}-fold cross-validation, {SPLITS[s]}:")
        t0 = time.perf_counter()
        results[s] = cross_validate(data, soil=nominal, width=width, folds=folds, seed=seed, by_dig=(s == "digs"),
                                  progress=say)
        say(f"  [{time.perf_counter() - t0:.0f} s]\n")
        report["table4"][s] = {f"{r.method}/{r.basis or '-'}": round(r.mae, 2) for r in results[s]}
    if len(results) == 2:
        say(format_table4(results["digs"], data, folds=folds, beside=results["samples"])
            + f"\n  whole digs held out; in parentheses, shuffled samples (the thesis' protocol). {FLATTERY}")
    else:
        for s in results:
            say(format_table4(results[s], data, folds=folds) + f"\n  split: {SPLITS[s]}")
    say("\nmeasuring training and prediction costs ...")
    costs = measure_costs(data, soil=nominal, width=width, seed=seed)
    say(format_table5(costs))
    report["table5"] = {c.method: {"train_s": c.train_s, "query_ms": c.query_ms, "batch_us": c.batch_us,
                                 "bytes": c.nbytes} for c in costs}
    say("\n" + format_weights(GlobalRegression(get_basis("mechanics")).fit(data.samples, data.forces)))
    fig_split = "digs" if "digs" in results else splits[0]
    png = plot_large_force_errors(out / "fig81_large_force_errors.png", results[fig_split], data,
                                title=f"Fig. 81: errors on forces above 300 N ({SPLITS[fig_split]}, mechanics basis)")
    errs = large_force_errors(results[fig_split], data)
    report["fig81"] = {k: {"n": int(e.size), "mean": float(e.mean()), "mae": float(np.abs(e).mean())}
                       for k, e in errs.items()}
    say(f"\nwrote {png}")
    if compare:
        overrides = {"robot": {"joints": {"wrist_pitch": {"torque_limit_nm": wrist_limit}}}} if wrist_limit else {}
        limit = f"wrist limit {wrist_limit:.0f} N m" if wrist_limit else "configured wrist limit"
        say(f"\nclosed-loop comparison: {episodes} episodes of at most {dig_budget} digs in {soil_name}, {limit}")
        rows = compare_predictors(soil=soil_name, episodes=episodes, seed=seed + 100, dig_budget=dig_budget,
                                method=method, forgetting=forgetting, prior=data, overrides=overrides,
                                progress=say)
        say(format_comparison(rows))
        report["compare"] = {r.predictor: {"digs": r.total("digs"), "stalls": r.total("stalls"),
                                         "dug_l_per_dig": r.mean("dug_l_per_dig"),
                                         "removed_fraction": r.mean("removed_fraction")} for r in rows}
    report["arguments"] = {"soil": soil, "digs": digs, "seed": seed, "folds": folds, "split": split,
                           "episodes": episodes, "dig_budget": dig_budget, "wrist_limit": wrist_limit,
                           "method": method, "forgetting": forgetting}
    out.mkdir(parents=True, exist_ok=True)
    (out / "learn.json").write_text(json.dumps(report, indent=1))
    say(f"numbers written to {out / 'learn.json'}")
    return report


@dataclasses.dataclass
class ComparisonRow:
    """One predictor's episodes: per-episode summaries and learning histories."""

    predictor: str
    summaries: list[dict[str, Any]]
    histories: list[list[DigLearning]]

    def mean(self, key: str) -> float:
        return float(np.mean([s[key] for s in self.summaries]))

    def total(self, key: str) -> float:
        return float(np.sum([s[key] for s in self.summaries]))


def compare_predictors(*, soil: str | None = None, episodes: int = 2, seed: int = 100, goal: str = "straight",
                       dig_budget: int = 8, method: str = "global", basis: str = "mechanics",
                       forgetting: float = 1.0, prior: ForceDataset | None = None,
                       overrides: dict[str, Any] | None = None,
                       progress: Callable[[str], None] | None = None) -> list[ComparisonRow]:
    """The same episodes (seeds ``seed``, ``seed + 1``, ...) planned with the nominal wedge model and
    with a learned predictor updated after every dig, from scratch and (when ``prior`` is given)
    starting from ``prior``.

    Args:
        soil: soil preset (default: the scene's); goal: trench goal name; dig_budget: digs per episode.
        method, basis, forgetting: the learned predictor (see :func:`~excavsim.learning.predictors.make_model`).
        overrides: ``robot``, ``scene``, ``planner``, ``executor``, ``sensing`` overrides as in an
            :class:`~excavsim.loop.scenario.EpisodeSpec`.
        progress: called with a line per episode.
    """
    from excavsim.loop.scenario import EpisodeSpec, episode_summary, run_spec

    say = progress or (lambda _s: None)
    variants: list[tuple[str, Callable[[], OnlineLearning | None]]] = [
        ("nominal wedge", lambda: None),
        (f"learned online ({method}, {basis})", lambda: OnlineLearning(method, basis=basis, forgetting=forgetting)),
    ]
    if prior is not None and len(prior):
        variants.append((f"learned, prior {prior.n_digs} digs + online",
                         lambda: OnlineLearning(method, basis=basis, forgetting=forgetting, prior=prior)))
    rows = []
    for name, make in variants:
        row = ComparisonRow(name, [], [])
        for e in range(episodes):
            spec = EpisodeSpec(name=f"compare-{e}", goal=goal, soil=soil, seed=seed + e, dig_budget=dig_budget,
                             **(overrides or {}))
            observer = make()
            summary = episode_summary(run_spec(spec, observer=observer))
            row.summaries.append(summary)
            row.histories.append(observer.history if observer else [])
            say(f"  {name:<40} seed {seed + e}: {summary['digs']} digs, {summary['stalls']} stalls, "
                f"{summary['dug_l_per_dig']:.1f} l per dig, {100 * summary['removed_fraction']:.0f} % removed "
                f"({summary['end']})")
        rows.append(row)
    return rows


def format_comparison(rows: Sequence[ComparisonRow]) -> str:
    """Stalls, soil per dig and the predictors' errors, one line per predictor."""
    lines = [f"{'predictor':<40}{'episodes':>9}{'digs':>6}{'stalls':>7}{'l/dig':>7}{'removed':>9}"
             f"{'wrist peak':>11}{'err learned':>12}{'err nominal':>12}"]
    for r in rows:
        hist = [h for hs in r.histories for h in hs]
        learned = np.nanmean([h.learned_mae for h in hist]) if any(np.isfinite(h.learned_mae) for h in hist) \
            else math.nan
        nominal = np.mean([h.nominal_mae for h in hist]) if hist else math.nan
        lines.append(f"{r.predictor:<40}{len(r.summaries):>9}{r.total('digs'):>6.0f}{r.total('stalls'):>7.0f}"
                     f"{r.mean('dug_l_per_dig'):>7.1f}{100 * r.mean('removed_fraction'):>8.0f}%"
                     f"{r.mean('peak_wrist_pitch_nm'):>11.0f}{learned:>12.0f}{nominal:>12.0f}")
    lines.append("l/dig: soil in the bucket per dig (truth); removed: of the goal volume; wrist peak: mean over "
                 "episodes [N m]; err: mean |F| error [N] on each dig before learning from it")
    return "\n".join(lines)
