"""Learning while digging: the planner's predictor updated after every dig (000_a3ca905d8c6d92bf.txt §5.2).

:class:`OnlineLearning` is an :class:`~excavsim.loop.episode.EpisodeObserver`: at the start of an
episode it installs a :class:`~excavsim.learning.adapter.LearnedForcePredictor` on the rig's
planner (the nominal wedge model answers until the model has data, unless it starts from a prior
data set); after every scan it binds the map's terrain; after every dig it turns the execution
record into force samples (the same encoding as the training data) and ``update``\\ s the model
with them. Its ``history`` logs, per dig, the learned and the nominal prediction errors on that
dig before the update: the learning curve.

:func:`compare_predictors` runs the same episodes with the nominal wedge model and with learned
predictors and reports stalls and the soil dug per dig (the campaign of issue #8).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from excavsim.learning.adapter import LearnedForcePredictor
from excavsim.loop.collect import TipTrace
from excavsim.learning.dataset import ForceDataset, samples_from_record
from excavsim.learning.encoding import Terrain
from excavsim.learning.evaluate import magnitude
from excavsim.learning.predictors import ForceModel, WedgeModel, make_model
from excavsim.loop.episode import EpisodeObserver


@dataclasses.dataclass(frozen=True)
class DigLearning:
    """What one dig taught: its samples, and the mean |F| errors [N] on it before the update."""

    index: int
    samples: int
    learned_mae: float  # of the predictor the planner used for this dig (NaN while nominal)
    nominal_mae: float  # of the nominal wedge model


class OnlineLearning(EpisodeObserver):
    """Installs a learned force predictor on the planner and updates it after every dig.

    Args:
        model: a :class:`ForceModel`, or a method name of :data:`~excavsim.learning.predictors.METHODS`
            (default: global regression, whose recursive update, eq. 22, is the cheapest).
        basis: the basis when ``model`` is a name.
        forgetting: the forgetting factor of eq. 22 when ``model`` names a global regression: below 1
            the model follows the soil of this episode rather than the prior's average.
        prior: a data set to fit the model on before the first dig.
        min_digs: without a prior, the nominal wedge model plans until the model has learned from
            this many digs (a model of one dig extrapolates wildly to the others).
        progress: called with one line per dig.
    """

    def __init__(self, model: ForceModel | str = "global", *, basis: str = "mechanics", forgetting: float = 1.0,
                 prior: ForceDataset | None = None, min_digs: int = 3,
                 progress: Callable[[str], None] | None = None):
        self.model = make_model(model, basis, forgetting=forgetting) if isinstance(model, str) else model
        self.prior = prior
        self.min_digs = int(min_digs)
        self.say = progress or (lambda _s: None)
        self.history: list[DigLearning] = []
        self.data = ForceDataset.empty()
        self.predictor: LearnedForcePredictor | None = None

    def started(self, sim, rig, goal_mask, goal_z) -> None:
        self.rig = rig
        self.trace = TipTrace(sim.model, rig.arm)
        self.waist = math.radians(rig.goal.waist_deg)
        self.epsilon = math.radians(rig.planner_cfg.epsilon_deg)
        nominal = rig.planner.predictor
        soil = getattr(nominal, "soil", None)
        self.nominal = WedgeModel(soil, rig.width, fit_params=False) if soil is not None else None
        self.predictor = LearnedForcePredictor(self.model, density_kg_m3=rig.planner.density,
                                               epsilon_rad=self.epsilon, nominal=nominal)
        self.predictor.active = False
        if self.prior is not None and len(self.prior):
            self.model.fit(self.prior.samples, self.prior.forces)
            self.predictor.active = True
        rig.planner.predictor = self.predictor
        self._terrain: Terrain | None = None
        self._phases = None

    def scanned(self, index: int, emap, accuracy) -> None:
        self._terrain = Terrain.from_map(emap, self.rig.arm, self.waist, self.rig.width)
        self.predictor.bind(self._terrain)

    def planned(self, index: int, plan, fallback) -> None:
        if plan.action is not None:
            self._phases = plan.phases
        else:
            self._phases = None if fallback is None else fallback.phases
        self.trace.clear()

    def stepped(self, sim) -> None:
        self.trace(sim)

    def dug(self, index: int, record, metrics) -> None:
        t, tip = self.trace.arrays()
        self.trace.clear()
        if self._phases is None or self._terrain is None or len(t) < 2:
            return
        rows = samples_from_record(record, trace_times=t, trace_poses=tip, terrain=self._terrain,
                                   phases=self._phases, epsilon=self.epsilon, width=self.rig.width,
                                   dig=self.data.n_digs)
        if not len(rows):
            return
        observed = magnitude(rows.forces)
        learned = (float(np.mean(np.abs(magnitude(self.model.predict(rows.samples)) - observed)))
                   if self.predictor.active else math.nan)
        nominal = (float(np.mean(np.abs(magnitude(self.nominal.predict(rows.samples)) - observed)))
                   if self.nominal is not None else math.nan)
        self.model.update(rows.samples, rows.forces)
        self.data = ForceDataset.concat([self.data, rows])
        self.predictor.active = self.predictor.active or self.data.n_digs >= self.min_digs
        self.history.append(DigLearning(index, len(rows), learned, nominal))
        self.say(f"  learned from dig {index}: {len(rows)} samples; error on it before the update "
                 f"{learned:.0f} N learned, {nominal:.0f} N nominal")


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
