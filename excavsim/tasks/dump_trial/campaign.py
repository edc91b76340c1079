"""The truck-loading campaign: tuned against untuned over seeds and soils, and a target moved mid-run.

Rowe 1997 §6.2 (Fig. 12). For every soil and seed, three runs of ``trials`` trials
(:func:`excavsim.tasks.dump_trial.tuning.tune`): **tuned** (the online learner), **untuned** (every trial from the
computed parameters plus the same small noise, ``learn=False``: what the script does without
learning) and, with ``retarget``, **moved** (tuned, the target moved before trial ``retarget[0]``:
does it re-learn?). The table gives, per run, the mean cost, time and squared placement error of the
first and the last ``window`` trials (``window`` = the initial trials, 6 as in §6.2) and, for the
moved runs, of the ``window`` trials after the move; a run is *re-learnt* when its last trials cost
less than those just after the move. Each trial restarts the world with the same seed, so a run is
bit-reproducible on one machine; between machines the numbers are statistical (README).
"""

from __future__ import annotations

import csv
import dataclasses
import math
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from excavsim.config import get_soil
from excavsim.errors import ConfigError
from excavsim.tasks.dump_trial import trial as truck
from excavsim.tasks.dump_trial import tuning


@dataclasses.dataclass(frozen=True)
class Window:
    """Means over a window of trials: cost, time [s], squared placement error [m^2], failed trials."""

    cost: float
    time_s: float
    sq_error_m2: float
    failed: int

    @classmethod
    def of(cls, trials: Sequence[truck.Trial], cfg: truck.TruckConfig) -> Window:
        if not trials:
            return cls(math.nan, math.nan, math.nan, 0)
        return cls(float(np.mean([truck.trial_cost(t, cfg) for t in trials])),
                   float(np.mean([t.time_s for t in trials])),
                   float(np.mean([truck.placement_error2(t, cfg) for t in trials])),
                   int(sum(t.failed for t in trials)))


@dataclasses.dataclass(frozen=True)
class RunSummary:
    """One run of the campaign: its soil, seed and kind (tuned, untuned, moved) and its windows."""

    soil: str
    seed: int
    kind: str
    first: Window
    last: Window
    after_move: Window | None = None


def run_tuning_campaign(*, seeds: Sequence[int], soils: Sequence[str], trials: int,
                        retarget: tuple[int, float, float] | None = None, cfg: truck.TruckConfig | None = None,
                        out: Path | None = None, progress: Callable[[str], None] | None = None) -> list[RunSummary]:
    """Run the campaign (see the module docstring); writes ``truck_campaign.csv`` (one row per trial) and
    ``truck_campaign.txt`` (the table) into ``out`` when given.

    Raises:
        ExcavsimError: an unknown soil (the message lists the presets), fewer trials than two windows, or
            a move outside the run.
    """
    cfg = cfg or truck.load_truck_config()
    for s in soils:
        get_soil(s)  # ConfigError (an ExcavsimError) naming the presets
    window = cfg.initial_trials
    if trials < 2 * window:
        raise ConfigError(f"a campaign run needs at least {2 * window} trials (first and last {window}); "
                          f"given {trials}")
    if retarget is not None and not window <= retarget[0] <= trials - window:
        raise ConfigError(f"the target can move before trial {window + 1} ... {trials - window + 1} of a "
                          f"{trials}-trial run (a window before and after it); given {retarget[0] + 1}")
    runs: list[RunSummary] = []
    rows: list[dict] = []
    for soil in soils:
        for seed in seeds:
            base = truck.nominal_params(cfg, seed=seed, soil=soil)  # the same for the three runs
            kinds = {"tuned": dict(learn=True), "untuned": dict(learn=False)}
            if retarget is not None:
                kinds["moved"] = dict(learn=True, retarget=retarget)
            for kind, kw in kinds.items():
                ts = tuning.tune(trials, cfg, seed=seed, soil=soil, base=base, **kw)
                after = None
                if kind == "moved":
                    after = Window.of(ts[retarget[0]:retarget[0] + window], cfg)
                summary = RunSummary(soil, seed, kind, Window.of(ts[:window], cfg), Window.of(ts[-window:], cfg),
                                     after)
                runs.append(summary)
                if progress is not None:
                    progress(format_tuning_line(summary))
                for t in ts:
                    o = truck.trial_objective(t, cfg)
                    rows.append({"soil": soil, "seed": seed, "run": kind, "trial": t.index + 1, "source": t.source,
                                 "cost": truck.trial_cost(t, cfg), "time_s": t.time_s,
                                 "sq_error_m2": truck.placement_error2(t, cfg), "failed": int(t.failed),
                                 "target_r_m": o.r_d, "target_theta_deg": math.degrees(o.theta_d)})
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        with (out / "truck_campaign.csv").open("w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            for row in rows:
                w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in row.items()})
        (out / "truck_campaign.txt").write_text(format_tuning_table(runs, window) + "\n")
    return runs


def compare_tuning(*, seeds: Sequence[int], soils: Sequence[str] | None, trials: int, out: Path,
                   retarget: tuple[int, float, float] | None = None, cfg: truck.TruckConfig | None = None,
                   say: Callable[[str], None] = print) -> list[RunSummary]:
    """``excavsim tune --compare``: :func:`run_tuning_campaign` over ``soils`` (default the scene's) with a
    line per run and the table said at the end."""
    from excavsim.config import load_scene_config

    cfg = cfg or truck.load_truck_config()
    soils = list(soils or [load_scene_config().soil])
    say(f"excavsim tune --compare: tuned vs untuned{' and a moved target' if retarget else ''}, "
        f"{trials} trials, seeds {' '.join(map(str, seeds))}, soils {' '.join(soils)} "
        "(Rowe 1997 §6.2)")
    runs = run_tuning_campaign(seeds=seeds, soils=soils, trials=trials, retarget=retarget, cfg=cfg, out=Path(out),
                        progress=say)
    say(format_tuning_table(runs, cfg.initial_trials))
    say(f"wrote {Path(out) / 'truck_campaign.csv'} and truck_campaign.txt")
    return runs


def format_tuning_line(r: RunSummary) -> str:
    """One line: a run's first and last windows (and the one after the move)."""
    def w(x: Window) -> str:
        return f"{x.cost:7.2f} {x.time_s:5.2f} s {x.sq_error_m2:.4f} m^2"
    moved = f"  after move {w(r.after_move)}" if r.after_move is not None else ""
    return f"{r.soil:14s} seed {r.seed:3d} {r.kind:8s} first {w(r.first)}{moved}  last {w(r.last)}"


def format_tuning_table(runs: Sequence[RunSummary], window: int) -> str:
    """The campaign's table: per soil and seed the last-window cost, time and error of the tuned and
    the untuned runs, the moved run after the move and at the end, and the verdicts; then the means
    over the seeds of each soil."""
    head = (f"Truck loading campaign (Rowe 1997 §6.2): means of the first / last {window} trials "
            f"(cost, time [s], squared placement error [m^2])\n\n"
            f"| soil | seed | tuned first | tuned last | untuned last | tuned beats untuned | moved: after move "
            f"| moved: last | re-learnt |\n| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    lines = [head]
    by = {(r.soil, r.seed, r.kind): r for r in runs}
    keys = sorted({(r.soil, r.seed) for r in runs}, key=lambda k: (list(dict.fromkeys(r.soil for r in runs))
                                                                    .index(k[0]), k[1]))

    def cell(x: Window | None) -> str:
        return "-" if x is None else f"{x.cost:.1f}, {x.time_s:.2f}, {x.sq_error_m2:.4f}"

    wins = relearnt = moved = 0
    for soil, seed in keys:
        tu, un, mv = by.get((soil, seed, "tuned")), by.get((soil, seed, "untuned")), by.get((soil, seed, "moved"))
        beats = tu is not None and un is not None and tu.last.cost < un.last.cost
        wins += beats
        re = mv is not None and mv.last.cost < mv.after_move.cost
        relearnt += re
        moved += mv is not None
        lines.append(f"| {soil} | {seed} | {cell(tu.first if tu else None)} | {cell(tu.last if tu else None)} | "
                     f"{cell(un.last if un else None)} | {'yes' if beats else 'no'} | "
                     f"{cell(mv.after_move if mv else None)} | {cell(mv.last if mv else None)} | "
                     f"{('yes' if re else 'no') if mv else '-'} |")
    lines.append("")
    for soil in dict.fromkeys(r.soil for r in runs):
        def mean(kind: str, part: str) -> str:
            ws = [getattr(r, part) for r in runs if r.soil == soil and r.kind == kind and getattr(r, part)]
            if not ws:
                return "-"
            return (f"{np.mean([w.cost for w in ws]):.1f}, {np.mean([w.time_s for w in ws]):.2f} s, "
                    f"{np.mean([w.sq_error_m2 for w in ws]):.4f} m^2")
        lines.append(f"{soil}, mean over seeds: tuned first {mean('tuned', 'first')}; tuned last "
                     f"{mean('tuned', 'last')}; untuned last {mean('untuned', 'last')}"
                     + (f"; moved after move {mean('moved', 'after_move')} -> last {mean('moved', 'last')}"
                        if moved else ""))
    lines.append(f"\ntuned beats untuned (last {window}) in {wins} of {len(keys)} runs"
                 + (f"; the moved target re-learnt in {relearnt} of {moved}" if moved else ""))
    return "\n".join(lines)
