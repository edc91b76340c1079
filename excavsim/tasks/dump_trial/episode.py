"""Truck loading as a task of the episode specification (``task: dump_trial``, Rowe 1997 §6.2).

An :class:`~excavsim.loop.scenario.EpisodeSpec` with ``task: dump_trial`` is one trial of
:mod:`excavsim.tasks.dump_trial.trial` on the T3: the fixed dig, a scan, the mass-excavation script with the
parameters computed for the site (§4.2; the self-tuning over trials is ``excavsim tune``), the dump, a
scan again. The spec's ``dump_trial:`` overrides ``configs/dump_trial.yaml`` (validated by
:class:`~excavsim.tasks.dump_trial.config.TruckFile`); ``soil`` and ``seed`` choose the world. This module is what
the platform's catalog (:mod:`excavsim.loop.catalog`) names: the task class, the campaign row
(:func:`summary`), the per-cycle rows (:func:`dig_rows`), the printed table (:func:`format_run`) and
the Rerun recorder of a trial (:func:`episode_recorder`, ``excavsim run SPEC --record FILE.rrd``).

With ``dump_trial: {tuning: {trials: N, learn: true|false}}`` the episode is a self-tuning run instead
(:mod:`excavsim.tasks.dump_trial.tuning`): N trials, each in a fresh world, the tuner (LWR and the simplex,
§5) choosing their parameters, or the untuned baseline; its campaign row gives the first and the last
window's means, so that a campaign grid compares tuned and untuned over soils and seeds.
"""

from __future__ import annotations

import math
from typing import Any

from excavsim.tasks.dump_trial.config import TruckFile
from excavsim.errors import ConfigError
from excavsim.loop.catalog import summary_number
from excavsim.loop.episode import Episode
from excavsim.tasks.dump_trial.trial import Trial, TruckTask, truck_config
from excavsim.tasks.dump_trial.tuning import Tuner, TuningRun, TuningTask, windows



class TruckTrial(TruckTask):
    """One truck-loading trial of an episode specification: a :class:`~excavsim.tasks.dump_trial.trial.TruckTask`
    with the computed parameters (§4.2) on the trial's own dig.

    Args:
        machine: the machine; only ``t3`` does this task (Rowe's script runs on the T3 here).
        cfg: ``configs/dump_trial.yaml`` with the spec's overrides, validated.
        soil: a soil preset of configs/soils.yaml (default the scene's).
    """

    def __init__(self, machine: str, *, cfg: TruckFile, soil: str | None = None):
        if machine != "t3":
            raise ConfigError(f"machine {machine!r} does not do task dump_trial; allowed: t3")
        self.file = cfg
        # the trial keeps its trace (the servos' joints, the tip, the script's steps): what a recording
        # shows; it only reads the servos, so the trial is the same with it or without it
        super().__init__(None, truck_config(cfg), source="computed", soil=soil, trace=True)


def spec_episode(spec, resolved, *, progress=None, observer=None) -> Episode:
    """The :class:`~excavsim.loop.episode.Episode` of a dump-trial specification (not yet reset): one trial with
    the computed parameters (one cycle), or with ``dump_trial.tuning`` a tuning run of its trials (``resolved``:
    configs/dump_trial.yaml with the spec's overrides)."""
    tuning = resolved.tuning
    if tuning is None:
        return Episode(TruckTrial(spec.machine_name, cfg=resolved, soil=spec.soil), dig_budget=1,
                       progress=progress, observer=observer)
    if spec.machine_name != "t3":
        raise ConfigError(f"machine {spec.machine_name!r} does not do task dump_trial; allowed: t3")
    return Episode(TuningTask(truck_config(resolved), learn=tuning.learn, soil=spec.soil),
                   dig_budget=tuning.trials, progress=progress, observer=observer)


def episode_recorder(path: str | None, *, live: str | None = None):
    """The Rerun recorder of a dump trial (or a tuning run's trials) to ``path`` and/or streamed to the viewer at
    ``live`` (a gRPC URL)."""
    from excavsim.tasks.dump_trial.recording import TrialRecorder

    return TrialRecorder(path, live=live)


def trial_end(trial: Trial) -> tuple[str, str]:
    """How a trial ended, in the platform's words: ``done`` (the script ended and emptied the bucket),
    ``timeout`` (the script did not end) or ``budget`` (its one cycle ran but left too much in the
    bucket: a failure, §5.4.1), with the reason."""
    kept = 1.0 - trial.dumped_m3 / trial.loaded_m3 if trial.loaded_m3 > 0 else 1.0
    if trial.outcome != "end":
        return "timeout", f"the mass-excavation script did not end ({trial.outcome})"
    if trial.failed:
        return "budget", (f"the trial's script ran but left {100 * kept:.0f} % of the load in the bucket "
                          f"(a failure: more than {100 * (1 - trial.min_dumped_fraction):.0f} %, §5.4.1)")
    return "done", f"the script ended and dumped {100 * (1 - kept):.0f} % of the load"


def progress_text(s: dict[str, Any]) -> str:
    """One episode's :func:`summary` in a few words, for the progress lines of ``campaign`` and ``regress``
    (a key missing or not finite prints ``?``)."""
    num = summary_number(s)
    if s.get("tuning"):  # a tuning run: its first and last windows
        return (f"{s['tuning']}, {num('trials')} trials, cost {num('first_cost', fmt='.2f')} (first) -> "
                f"{num('last_cost', fmt='.2f')} (last), cycle {num('cycle_s', fmt='.2f')} s")
    return f"{num('dumped_l', fmt='.1f')} l dumped, {num('missed_l', fmt='.1f')} l missed, cycle {num('cycle_s', fmt='.2f')} s"

def summary(trial: Trial | TuningRun) -> dict[str, Any]:
    """A trial's metrics as a flat dict of JSON numbers and strings (a campaign row; ``regress``'s
    sample): ``end``/``reason`` (:func:`trial_end`), ``digs`` (1: the one cycle), the load in the bucket
    after the fixed dig (``loaded_l``, also ``dug_l_per_dig``), what the dump emptied (``dumped_l``, its
    share ``dumped_fraction``), what stayed in the bucket (``kept_l``), the soil that missed the truck's
    bed (``missed_l``, the spillage, :func:`~excavsim.tasks.dump_trial.trial.missed_volume`), the script's cycle
    time (``cycle_s``, §6.2), the pile measured on the maps (``pile_r_m``, ``pile_theta_deg``) and its
    placement error (``placement_error_cm``), the cost of §6.2 (``cost``), ``failed`` (§5.4.1), and
    the simulated and wall times. A tuning run's (:func:`run_summary`) gives the same keys as the means
    of its last window, and the first window's beside them."""
    if isinstance(trial, TuningRun):
        return run_summary(trial)
    end, reason = trial_end(trial)
    loaded, dumped = trial.loaded_m3, trial.dumped_m3
    o, r, theta = trial.objective, trial.pile.r, trial.pile.theta
    err2 = (o.r_d - r) ** 2 + o.r_d ** 2 * (o.theta_d - theta) ** 2 if o is not None else math.nan
    cost = float(o.cost(trial.time_s, r, theta, float(trial.failed))) if o is not None else math.nan
    return {
        "task": "dump_trial", "machine": "t3", "end": end, "reason": reason, "digs": 1,
        "dug_l_per_dig": 1000 * loaded, "loaded_l": 1000 * loaded, "dumped_l": 1000 * dumped,
        "dumped_fraction": dumped / loaded if loaded > 0 else 0.0, "kept_l": 1000 * (loaded - dumped),
        "missed_l": 1000 * trial.missed_m3, "cycle_s": trial.time_s, "pile_r_m": trial.pile.r,
        "pile_theta_deg": math.degrees(trial.pile.theta),
        "placement_error_cm": 100 * math.sqrt(err2), "cost": cost, "failed": int(trial.failed), "outcome": trial.outcome,
        "sim_s": trial.sim_s, "wall_s": trial.wall_s,
    }


def run_summary(run: TuningRun) -> dict[str, Any]:
    """A tuning run's metrics as a flat dict (a campaign row): ``tuning`` (tuned or untuned), ``trials``
    (also ``digs``), ``end`` (``done`` when every trial ran and none of the last window failed, else
    ``budget``), the first and the last window's mean cost, time and squared placement error
    (``first_cost``, ``last_cost`` ...; the window is ``learning.initial_trials``, 6 as in §6.2), and the
    trial metrics of :func:`summary` (``cost``, ``cycle_s``, ``placement_error_cm``, ``dumped_l`` ...)
    as means over the last window; ``failed`` counts the run's failed trials."""
    ts, n = run.tuning_trials, run.window
    last = [summary(t) for t in ts[-n:]]
    w = windows(run)
    failed_last = sum(t.failed for t in ts[-n:])
    end = "done" if ts and not failed_last else "budget"
    kind = "tuned" if run.learn else "untuned"
    reason = (f"{len(ts)} trials {kind}: last {n} mean cost {w['last_cost']:.2f} (first {n}: {w['first_cost']:.2f})"
              + (f", {failed_last} of the last {n} failed" if failed_last else ""))
    mean = {k: float(sum(r[k] for r in last) / len(last)) if last else math.nan
            for k in ("loaded_l", "dumped_l", "dumped_fraction", "kept_l", "missed_l", "cycle_s", "pile_r_m",
                      "pile_theta_deg", "placement_error_cm", "cost")}
    return {"task": "dump_trial", "machine": "t3", "tuning": kind, "end": end, "reason": reason, "digs": len(ts),
            "trials": len(ts), "dug_l_per_dig": mean["loaded_l"], **mean, **w,
            "failed": int(sum(t.failed for t in ts)), "sim_s": float(sum(t.sim_s for t in ts)), "wall_s": run.wall_s}


def dig_rows(trial: Trial | TuningRun) -> list[dict[str, Any]]:
    """The trial's one cycle as a per-dig row: its parameters' source, the load, what was dumped and
    missed [l], the cycle time [s] and the pile, measured and true; a tuning run's trials one row each."""
    if isinstance(trial, TuningRun):
        return [{**row, "dig": t.index + 1} for t in trial.tuning_trials for row in dig_rows(t)]
    return [{"dig": 1, "source": trial.source, "loaded_l": 1000 * trial.loaded_m3, "dumped_l": 1000 * trial.dumped_m3,
             "missed_l": 1000 * trial.missed_m3, "cycle_s": trial.time_s, "pile_r_m": trial.pile.r,
             "pile_theta_deg": math.degrees(trial.pile.theta), "true_r_m": trial.true.r,
             "true_theta_deg": math.degrees(trial.true.theta), "outcome": trial.outcome}]


def format_run(trial: Trial | TuningRun) -> str:
    """A trial as printed by ``excavsim trench --spec`` (or ``run``): its outcome and numbers; a tuning
    run's first and last windows."""
    if isinstance(trial, TuningRun):
        s = run_summary(trial)
        return (f"truck-loading tuning run (Rowe 1997 §6.2), {s['tuning']}: {s['reason']}\n"
                f"  first {trial.window}: cost {s['first_cost']:.2f}, time {s['first_time_s']:.2f} s, squared error "
                f"{s['first_sq_error_m2']:.4f} m^2\n"
                f"  last {trial.window}:  cost {s['last_cost']:.2f}, time {s['last_time_s']:.2f} s, squared error "
                f"{s['last_sq_error_m2']:.4f} m^2; {s['failed']} failed trials")
    s = summary(trial)
    return (f"truck-loading trial (Rowe 1997 §6.2): {s['reason']}\n"
            f"  loaded {s['loaded_l']:.1f} l, dumped {s['dumped_l']:.1f} l, {s['missed_l']:.1f} l beside the "
            f"truck's bed; cycle {s['cycle_s']:.2f} s\n"
            f"  pile at r = {s['pile_r_m']:.3f} m, theta = {s['pile_theta_deg']:.1f} deg (target r = "
            f"{trial.r_d:.3f} m, theta = {math.degrees(trial.theta_d):.1f} deg): error "
            f"{s['placement_error_cm']:.1f} cm; cost {s['cost']:.2f}")
