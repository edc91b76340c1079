"""Self-tuning as the truck task's dig source: a tuning run is one episode of the platform (Rowe 1997 §5, §6.2).

:class:`Tuner` is a :class:`~excavsim.loop.digs.DigSource` of the truck task: each cycle (one trial) it
chooses the mass-excavation script's parameters, the first ``initial_trials`` from the computed
parameters plus small noise, then each from :func:`~excavsim.learning.lwr_tuning.select_action` on the
memory of the trials so far (``learn=False``: every trial from the computed parameters plus the same
noise, the untuned baseline), and it remembers how each trial went. :class:`TuningTask` is the truck
task of a run: every cycle is one trial in a fresh world of the run's seed (§6.2: the same soil every
trial), its result a :class:`TuningRun`. A trial of the run is the trial :func:`~excavsim.tasks.dump_trial.trial.tune`
runs, number for number (the same worlds, noise and memory): an episode specification with
``dump_trial: {tuning: {trials: N, learn: ...}}`` puts the comparison of ``excavsim tune --compare`` in a
campaign grid, over soils and seeds beside the other tasks.
"""

from __future__ import annotations

import csv
import dataclasses
from typing import ClassVar
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from excavsim.config import get_soil
from excavsim.execution.rowe_script.listing import rowe_script
from excavsim.execution.rowe_script.params import RoweParams
from excavsim.learning.lwr_tuning import Memory, select_action
from excavsim.loop.digs import Choice, DigSource
from excavsim.tasks.dump_trial.trial import (FRACTIONS, SCRIPT_JOINTS, TUNED, Trial, TruckConfig, TruckTask,
                                        load_truck_config, noise_scale, nominal_params, placement_error2, retargeted,
                                        run_trial, trial_cost, trial_objective, tuned_bounds)


@dataclasses.dataclass(frozen=True)
class TunedAction:
    """A tuner's choice for one trial (what :class:`~excavsim.loop.digs.Choice` carries as its plan)."""

    params: RoweParams
    x: np.ndarray  # the tuned parameters (TUNED's order)
    source: str  # "computed + noise" or "learned"
    predicted_cost: float = math.nan
    width: float = math.nan


class Tuner(DigSource):
    """The parameters of each trial of a run, chosen as :func:`~excavsim.tasks.dump_trial.trial.tune` chooses them.

    Args:
        cfg: the truck configuration (its objective, initial trials and noise, bounds).
        learn: False: every trial from the computed parameters plus the same small noise (the untuned baseline).
        seed: the run's seed (the noise's generator, as ``tune``'s).
    """

    def __init__(self, cfg: TruckConfig, *, learn: bool = True, seed: int = 0):
        self.cfg, self.learn = cfg, learn
        self.rng = np.random.default_rng((seed, 12))
        self.memory = Memory(len(TUNED))
        self.scale = noise_scale(cfg)
        self.base: RoweParams | None = None
        self.computed_until = cfg.initial_trials  # trials before this one run the computed parameters plus noise

    def bind(self, base: RoweParams) -> None:
        """The computed parameters of the run (§4.2) and the bounds of what the tuner may change about them."""
        self.base = base
        self.lo, self.hi = tuned_bounds(base, self.cfg)

    def retarget(self, cfg: TruckConfig, base: RoweParams, *, until: int) -> None:
        """The target moved (§5.4.4): ``cfg``'s objective, the parameters ``base`` computed for it, and
        computed trials (plus noise) before trial ``until``; the memory is kept (it maps actions to
        outcomes, whatever the target)."""
        self.cfg = cfg
        self.bind(base)
        self.computed_until = max(self.computed_until, until)

    def choose(self, task, emap) -> Choice:
        k = len(self.memory)  # the trial's index
        if not self.learn or k < self.computed_until or k < 2:
            x = np.clip(self.base.values(TUNED) + self.rng.normal(0.0, 1.0, len(TUNED)) * self.scale, self.lo, self.hi)
            action = TunedAction(self.base.with_values(TUNED, x), x, "computed + noise")
        else:
            sel = select_action(self.memory, self.cfg.objective, lower=self.lo, upper=self.hi)
            action = TunedAction(self.base.with_values(TUNED, sel.x), sel.x, "learned", sel.predicted_cost, sel.width)
        return Choice(rowe_script(action.params, SCRIPT_JOINTS), plan=action)

    def remember(self, x: np.ndarray, trial: Trial) -> None:
        """How the trial of the tuned parameters ``x`` went: its time, its pile and whether it failed."""
        self.memory.add(x, trial.time_s, trial.pile.r, trial.pile.theta, float(trial.failed))

    def learned(self, task, index: int, dig, trial: Trial, emap) -> str | None:
        self.remember(task.action.x, trial)
        return (f"  trial {index} ({trial.source}): {trial.outcome}, time {trial.time_s:.2f} s, pile r "
                f"{trial.pile.r:.3f} m theta {math.degrees(trial.pile.theta):.1f} deg, cost "
                f"{trial_cost(trial, self.cfg):.2f}" + (" FAILED" if trial.failed else ""))


@dataclasses.dataclass
class TuningRun:
    """A tuning run's trials in order, whether it learned, its configuration and its wall time [s]."""

    task: ClassVar[str] = "dump_trial"  # the task whose episode result it is
    tuning_trials: list[Trial]
    learn: bool
    cfg: TruckConfig
    wall_s: float = math.nan

    @property
    def window(self) -> int:
        """The trials of the first and of the last window (the initial trials, 6 as in §6.2)."""
        return max(1, self.cfg.initial_trials)


class TuningTask(TruckTask):
    """A self-tuning run (§6.2) as a task of the platform's :class:`~excavsim.loop.episode.Episode`: every cycle
    is one trial of the script in a fresh world of the run's seed, with the parameters the dig source (a
    :class:`Tuner`, by default one of ``learn``) chooses; an episode of ``trials`` cycles is the run.

    Args:
        cfg: the truck configuration.
        learn: the default tuner's (see :class:`Tuner`).
        soil: a soil preset of configs/soils.yaml (default the scene's).
    """

    def __init__(self, cfg: TruckConfig, *, learn: bool = True, soil: str | None = None):
        super().__init__(None, cfg, soil=soil, trace=True)
        self.learn = learn

    def reset(self, seed: int, world=None, digs: Tuner | None = None) -> tuple:
        if digs is not None and not isinstance(digs, Tuner):
            raise TypeError(f"a tuning run's dig source is a Tuner; given {type(digs).__name__}")
        self.seed = seed
        q = self.new_world(seed, world)
        self.tuner = digs or Tuner(self.cfg, learn=self.learn, seed=seed)
        self.tuner.bind(self.computed(q))
        self.params = self.tuner.base
        self.trials: list[Trial] = []
        self.trial = None
        return self.sim, self.cfg

    def budget_reason(self, budget: int) -> str:
        return f"the run's {budget} trials ran"

    def park(self) -> None:
        """Before every trial but the first: a fresh world of the run's seed and the fixed dig (§6.2)."""
        if self.trials:
            hooks = list(self.sim.step_hooks)  # the episode's observers see every trial's world
            self.new_world(self.seed)
            self.sim.step_hooks.extend(hooks)

    def choose(self, emap) -> Choice:
        choice = self.tuner.choose(self, emap)
        self.action: TunedAction = choice.plan
        self.params, self.index, self.source = self.action.params, len(self.trials), self.action.source
        return choice

    def execute(self, index, choice):
        dug, stop = super().execute(index, choice)
        trial = dug[0]
        trial.predicted_cost, trial.width = self.action.predicted_cost, self.action.width
        return dug, stop

    def after(self, index, choice, dug, say):
        (trial,) = dug
        self.trials.append(trial)
        line = self.tuner.learned(self, index, choice.dig, trial, None)
        if line:
            say(line)
        return None

    def result(self, end, reason, wall_s) -> TuningRun:
        return TuningRun(self.trials, self.tuner.learn, self.cfg, wall_s)


def windows(run: TuningRun) -> dict[str, float]:
    """The means of the first and the last window of a run: cost, time [s], squared placement error
    [m^2], and its failed trials (as the campaign of :mod:`excavsim.tasks.dump_trial.campaign` reports)."""
    ts, cfg, n = run.tuning_trials, run.cfg, run.window
    out: dict[str, float] = {}
    for name, part in (("first", ts[:n]), ("last", ts[-n:])):
        out[f"{name}_cost"] = float(np.mean([trial_cost(t, cfg) for t in part])) if part else math.nan
        out[f"{name}_time_s"] = float(np.mean([t.time_s for t in part])) if part else math.nan
        out[f"{name}_sq_error_m2"] = float(np.mean([placement_error2(t, cfg) for t in part])) if part else math.nan
    return out


# -- the tuning run outside a specification: excavsim tune ------------------------------------------

def tune(trials: int, cfg: TruckConfig | None = None, *, seed: int = 0,
         progress: Callable[[Trial], None] | None = None, learn: bool = True,
         retarget: tuple[int, float, float] | None = None, soil: str | None = None, observer=None,
         base: RoweParams | None = None) -> list[Trial]:
    """Run ``trials`` trials online, each in a fresh world (:func:`~excavsim.tasks.dump_trial.trial.run_trial`),
    their parameters chosen by a :class:`Tuner`; returns them in order.

    ``learn=False`` is the untuned baseline: every trial from the computed parameters plus the same small
    noise. ``retarget=(k, r_m, theta_rad)`` moves the dump target before trial ``k`` (0-based): the
    parameters are computed again for the new target, the memory is kept (it maps actions to outcomes,
    whatever the target) and only the objective changes; the first ``retarget_trials`` trials after the
    move run the new computed parameters plus noise (§5.4.4: the computed parameters are "a competent
    starting point"; without one the simplex, held near the data by the confidence bounds, creeps
    towards the new target a fraction of the data's range per trial). ``soil`` names a soil preset
    (configs/soils.yaml; default the scene's). ``observer`` (e.g. a recorder) is called with
    ``started(cfg, base)``, ``trial(trial, cfg, cost=, sq_error=)`` after every trial (the trial carries
    its :class:`TrialTrace`) and ``finished(trials, cfg)``. ``base``: the computed parameters for ``cfg``'s
    target, seed and soil when the caller has them (:func:`nominal_params`), else computed here."""
    cfg = cfg or load_truck_config()
    base = base if base is not None else nominal_params(cfg, seed=seed, soil=soil)
    tuner = Tuner(cfg, learn=learn, seed=seed)
    tuner.bind(base)
    out: list[Trial] = []
    if observer is not None:
        observer.started(cfg, base)
    for k in range(trials):
        if retarget is not None and k == retarget[0]:
            cfg = retargeted(cfg, retarget[1], retarget[2])
            tuner.retarget(cfg, nominal_params(cfg, seed=seed, soil=soil), until=k + cfg.retarget_trials)
        action: TunedAction = tuner.choose(None, None).plan
        trial = run_trial(action.params, cfg, seed=seed, index=k, source=action.source, soil=soil,
                          trace=observer is not None)
        trial.predicted_cost, trial.width = action.predicted_cost, action.width
        trial.r_d, trial.theta_d = cfg.site.r_d, cfg.site.theta_d
        tuner.remember(action.x, trial)
        out.append(trial)
        if observer is not None:
            observer.trial(trial, cfg, cost=trial_cost(trial, cfg), sq_error=placement_error2(trial, cfg))
        if progress is not None:
            progress(trial)
    if observer is not None:
        observer.finished(out, cfg)
    return out


def write_results(trials: list[Trial], cfg: TruckConfig, out: Path) -> tuple[Path, Path]:
    """The CSV table (one row per trial) and Fig. 12's learning curve (PNG) into ``out``."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    obj = cfg.objective
    rows = []
    for t in trials:
        err2 = placement_error2(t, cfg)
        row = {"trial": t.index + 1, "source": t.source, "cost": trial_cost(t, cfg), "time_s": t.time_s,
               "r_m": t.pile.r, "theta_deg": math.degrees(t.pile.theta), "sq_error_m2": err2,
               "true_r_m": t.true.r, "true_theta_deg": math.degrees(t.true.theta), "outcome": t.outcome,
               "failed": int(t.failed), "target_r_m": trial_objective(t, cfg).r_d,
               "target_theta_deg": math.degrees(trial_objective(t, cfg).theta_d),
               "loaded_l": 1e3 * t.loaded_m3, "dumped_l": 1e3 * t.dumped_m3, "predicted_cost": t.predicted_cost,
               "kernel_width": t.width, "wall_s": t.wall_s}
        row.update({f"{n}{'' if n in FRACTIONS else '_deg'}": v
                    for n, v in t.params.degrees().items() if n in TUNED})
        rows.append(row)
    csv_path = out / "tune.csv"
    with csv_path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        for row in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in row.items()})
    n = np.arange(1, len(rows) + 1)
    fig, ax = plt.subplots(3, 1, figsize=(6, 7), sharex=True)
    for a, key, label in zip(ax, ("cost", "time_s", "sq_error_m2"), ("cost", "time [s]", "squared error [m^2]")):
        a.plot(n, [r[key] for r in rows], "o-", ms=3)
        a.axvline(cfg.initial_trials + 0.5, color="grey", lw=0.8, ls="--")
        a.set_ylabel(label)
    ax[0].set_title(f"Self-tuned truck loading (Fig. 12 of Rowe 1997): target r = {obj.r_d} m, "
                    f"theta = {math.degrees(obj.theta_d):.0f} deg", fontsize=8)
    ax[-1].set_xlabel("trial")
    fig.tight_layout()
    png = out / "learning_curve.png"
    fig.savefig(png, dpi=120)
    plt.close(fig)
    return csv_path, png


def tune_and_report(trials: int, cfg: TruckConfig, out: Path, *, seed: int = 0, soil: str | None = None,
                    retarget: tuple[int, float, float] | None = None, record: str | None = None,
                    say: Callable[[str], None] = print) -> list[Trial]:
    """``excavsim tune``: :func:`tune` with a line per trial, the first and last windows' means, and
    the results written into ``out`` (:func:`write_results`).

    Args:
        trials: how many trials.
        cfg: the truck configuration.
        out: the output directory.
        seed: the world's seed.
        soil: a soil preset (default the scene's).
        retarget: (trial index, r [m], theta [rad]) of a target move.
        record: a Rerun file to record the trials to.
        say: where the lines go.
    """
    if soil:
        get_soil(soil)  # ConfigError naming the presets, before any trial
    say(f"excavsim tune: {trials} truck-loading trials, target r = {cfg.site.r_d} m, theta = "
        f"{math.degrees(cfg.site.theta_d):.1f} deg (Rowe 1997 §6.2)")

    def show(t: Trial) -> None:
        say(f"  {t.index + 1:3d} {t.source:16s} cost {trial_cost(t, cfg):8.2f}  time {t.time_s:5.2f} s  "
            f"r {t.pile.r:.3f} m  theta {math.degrees(t.pile.theta):5.1f} deg  {t.outcome}  ({t.wall_s:.2f} s wall)")

    observer = None
    if record:
        from excavsim.tasks.dump_trial.recording import TruckRecorder
        observer = TruckRecorder(record, seed=seed)
    done = tune(trials, cfg, seed=seed, progress=show, retarget=retarget, soil=soil, observer=observer)
    csv_path, png = write_results(done, cfg, Path(out))
    k = min(cfg.initial_trials, len(done))
    costs = [trial_cost(t, cfg) for t in done]
    times = [t.time_s for t in done]
    err2 = [placement_error2(t, cfg) for t in done]
    say(f"first {k}: mean cost {sum(costs[:k]) / k:.2f}, time {sum(times[:k]) / k:.2f} s, squared error "
        f"{sum(err2[:k]) / k:.4f} m^2; last {k}: mean cost {sum(costs[-k:]) / k:.2f}, time "
        f"{sum(times[-k:]) / k:.2f} s, squared error {sum(err2[-k:]) / k:.4f} m^2")
    say(f"wrote {csv_path} and {png}")
    if record:
        say(f"recorded to {record}; replay it with: excavsim replay {record}")
    return done
