"""The ``excavsim learn`` study: data, Tables 4 and 5, Fig. 81, and the nominal-versus-learned campaign.

:func:`run_learn` builds a force data set by digging in the simulator (or loads one), cross-validates
every method on every basis (Table 4, in the thesis' protocol of shuffled samples and holding out
whole digs), measures costs (Table 5), prints the global regression's weights (Table 2), draws
Fig. 81, writes the numbers to ``learn.json`` next to the data, and optionally compares the
nominal wedge model with learned predictors in closed-loop episodes.
"""

from __future__ import annotations

import json
import pathlib
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from excavsim.config import get_soil
from excavsim.errors import ExcavsimError
from excavsim.learning.bases import get_basis
from excavsim.learning.dataset import ForceDataset
from excavsim.learning.evaluate import (cross_validate, format_table4, format_table5, large_force_errors,
                                        measure_costs)
from excavsim.learning.figures import plot_large_force_errors
from excavsim.learning.predictors import METHODS, GlobalRegression

SPLITS = {"samples": "shuffled samples (the thesis' protocol)", "digs": "whole digs held out"}


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
        raise ExcavsimError(f"--digs must be at least 1; given {digs}")
    if folds < 2:
        raise ExcavsimError(f"--folds must be at least 2; given {folds}")
    if split not in (*SPLITS, "both"):
        raise ExcavsimError(f"--split must be one of {', '.join((*SPLITS, 'both'))}; given {split!r}")
    if not 0.0 < forgetting <= 1.0:
        raise ExcavsimError(f"--forgetting must lie in (0, 1]; given {forgetting}")
    if episodes < 1 or dig_budget < 1:
        raise ExcavsimError(f"--episodes and --dig-budget must be at least 1; given {episodes}, {dig_budget}")
    if method not in METHODS:
        raise ExcavsimError(f"--method must be one of {', '.join(METHODS)}; given {method!r}")
    if soil is not None:
        get_soil(soil)  # an unknown name fails here, listing the presets
    out = pathlib.Path(out)
    path = pathlib.Path(dataset) if dataset else out / f"dataset{default_format()}"
    if dataset and path.exists():
        data = ForceDataset.load(path)
        say(f"loaded {len(data)} samples of {data.n_digs} digs from {path}")
        if soil and data.meta.get("soil", soil) != soil:
            raise ExcavsimError(f"{path} holds data of soil {data.meta['soil']!r}, not {soil!r}: drop --soil or "
                                f"--dataset")
    else:
        from excavsim.loop.collect import collect_dataset

        say(f"collecting force data: {digs} random feasible digs (seed {seed})")
        data = collect_dataset(soil=soil, digs=digs, seed=seed, progress=say)
        say(f"saved {len(data)} samples of {data.n_digs} digs to {data.save(path)}")
    if len(data) < 10 * folds:
        raise ExcavsimError(f"{len(data)} samples are too few for {folds}-fold cross-validation; collect more digs")
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
        say(format_table4(results[s], data, folds=folds) + f"\n  split: {SPLITS[s]}")
        report["table4"][s] = {f"{r.method}/{r.basis or '-'}": round(r.mae, 2) for r in results[s]}
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
        from excavsim.loop.online import compare_predictors, format_comparison

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
