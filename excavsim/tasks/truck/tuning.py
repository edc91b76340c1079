"""Self-tuning as the truck task's dig source: a tuning run is one episode of the platform (Rowe 1997 §5, §6.2).

:class:`Tuner` is a :class:`~excavsim.loop.digs.DigSource` of the truck task: each cycle (one trial) it
chooses the mass-excavation script's parameters, the first ``initial_trials`` from the computed
parameters plus small noise, then each from :func:`~excavsim.learning.lwr_tuning.select_action` on the
memory of the trials so far (``learn=False``: every trial from the computed parameters plus the same
noise, the untuned baseline), and it remembers how each trial went. :class:`TuningTask` is the truck
task of a run: every cycle is one trial in a fresh world of the run's seed (§6.2: the same soil every
trial), its result a :class:`TuningRun`. A trial of the run is the trial :func:`~excavsim.tasks.truck.trial.tune`
runs, number for number (the same worlds, noise and memory): an episode specification with
``truck: {tuning: {trials: N, learn: ...}}`` puts the comparison of ``excavsim tune --compare`` in a
campaign grid, over soils and seeds beside the other tasks.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from excavsim.execution.mass_script import TUNED, MassParams, mass_script
from excavsim.learning.lwr_tuning import Memory, select_action
from excavsim.loop.digs import Choice, DigSource
from excavsim.tasks.truck.trial import (Trial, TruckConfig, TruckTask, noise_scale, placement_error2, trial_cost,
                                        tuned_bounds)


@dataclasses.dataclass(frozen=True)
class TunedAction:
    """A tuner's choice for one trial (what :class:`~excavsim.loop.digs.Choice` carries as its plan)."""

    params: MassParams
    x: np.ndarray  # the tuned parameters (TUNED's order)
    source: str  # "computed + noise" or "learned"
    predicted_cost: float = math.nan
    width: float = math.nan


class Tuner(DigSource):
    """The parameters of each trial of a run, chosen as :func:`~excavsim.tasks.truck.trial.tune` chooses them.

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
        self.base: MassParams | None = None

    def bind(self, base: MassParams) -> None:
        """The computed parameters of the run (§4.2) and the bounds of what the tuner may change about them."""
        self.base = base
        self.lo, self.hi = tuned_bounds(base, self.cfg)

    def choose(self, task, emap) -> Choice:
        k = len(self.memory)
        if not self.learn or k < self.cfg.initial_trials or k < 2:
            x = np.clip(self.base.tuned() + self.rng.normal(0.0, 1.0, len(TUNED)) * self.scale, self.lo, self.hi)
            action = TunedAction(self.base.with_tuned(x), x, "computed + noise")
        else:
            sel = select_action(self.memory, self.cfg.objective, lower=self.lo, upper=self.hi)
            action = TunedAction(self.base.with_tuned(sel.x), sel.x, "learned", sel.predicted_cost, sel.width)
        return Choice(mass_script(action.params), plan=action)

    def learned(self, task, index: int, dig, trial: Trial, emap) -> str | None:
        x = task.action.x
        self.memory.add(x, trial.time_s, trial.pile.r, trial.pile.theta, float(trial.failed))
        return (f"  trial {index} ({trial.source}): {trial.outcome}, time {trial.time_s:.2f} s, pile r "
                f"{trial.pile.r:.3f} m theta {math.degrees(trial.pile.theta):.1f} deg, cost "
                f"{trial_cost(trial, self.cfg):.2f}" + (" FAILED" if trial.failed else ""))


@dataclasses.dataclass
class TuningRun:
    """A tuning run's trials in order, whether it learned, its configuration and its wall time [s]."""

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
    [m^2], and its failed trials (as the campaign of :mod:`excavsim.tasks.truck.campaign` reports)."""
    ts, cfg, n = run.tuning_trials, run.cfg, run.window
    out: dict[str, float] = {}
    for name, part in (("first", ts[:n]), ("last", ts[-n:])):
        out[f"{name}_cost"] = float(np.mean([trial_cost(t, cfg) for t in part])) if part else math.nan
        out[f"{name}_time_s"] = float(np.mean([t.time_s for t in part])) if part else math.nan
        out[f"{name}_sq_error_m2"] = float(np.mean([placement_error2(t, cfg) for t in part])) if part else math.nan
    return out
