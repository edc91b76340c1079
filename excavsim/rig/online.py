"""Learning while digging: the planner's predictor updated after every dig (Singh 1995 §5.2).

:class:`OnlineLearning` is an :class:`~excavsim.handoff.episode.EpisodeObserver`: at the start of an
episode it installs a :class:`~excavsim.learning.adapter.LearnedForcePredictor` on the rig's
planner (the nominal wedge model answers until the model has data, unless it starts from a prior
data set); after every scan it binds the map's terrain; after every dig it turns the execution
record into force samples (the same encoding as the training data) and ``update``\\ s the model
with them. Its ``history`` logs, per dig, the learned and the nominal prediction errors on that
dig before the update: the learning curve.

:func:`~excavsim.studies.learning.compare.compare_predictors` runs the same episodes with the nominal wedge
model and with learned predictors and reports stalls and the soil dug per dig.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from excavsim.learning.adapter import LearnedForcePredictor
from excavsim.learning.dataset import ForceDataset
from excavsim.learning.evaluate import magnitude
from excavsim.learning.predictors import ForceModel, WedgeModel, make_model
from excavsim.rig.samples import DigSamples


@dataclasses.dataclass(frozen=True)
class DigLearning:
    """What one dig taught: its samples, and the mean |F| errors [N] on it before the update."""

    index: int
    samples: int
    learned_mae: float  # of the predictor the planner used for this dig (NaN while nominal)
    nominal_mae: float  # of the nominal wedge model


class OnlineLearning(DigSamples):
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
        peak_quantile: the predictor's peak margin is this quantile of the per-dig ratios of observed
            to predicted peak |F| (None: no peak margin); see
            :attr:`~excavsim.learning.adapter.LearnedForcePredictor.peak_margin`.
        peak_floor_n: digs whose predicted peak is below this [N] give no ratio (a near-empty skim's
            ratio says nothing about the digs that stall).
        progress: called with one line per dig.
    """

    def __init__(self, model: ForceModel | str = "global", *, basis: str = "mechanics", forgetting: float = 1.0,
                 prior: ForceDataset | None = None, min_digs: int = 3, peak_quantile: float | None = 0.8,
                 peak_floor_n: float = 100.0, progress: Callable[[str], None] | None = None):
        self.model = make_model(model, basis, forgetting=forgetting) if isinstance(model, str) else model
        self.prior = prior
        self.min_digs = int(min_digs)
        self.peak_quantile = peak_quantile
        self.peak_floor_n = float(peak_floor_n)
        self.say = progress or (lambda _s: None)
        self.history: list[DigLearning] = []
        self.data = ForceDataset.empty()
        self.predictor: LearnedForcePredictor | None = None

    def started(self, sim, rig, goal_mask, goal_z) -> None:
        super().started(sim, rig, goal_mask, goal_z)
        nominal = rig.planner.predictor
        soil = getattr(nominal, "soil", None)
        self.nominal = WedgeModel(soil, rig.width, fit_params=False) if soil is not None else None
        self.predictor = LearnedForcePredictor(self.model, density_kg_m3=rig.planner.density,
                                               epsilon_rad=self.epsilon, nominal=nominal,
                                               peak_quantile=self.peak_quantile)
        self.predictor.active = False
        if self.prior is not None and len(self.prior):
            self.model.fit(self.prior.samples, self.prior.forces)
            self.predictor.active = True
        rig.planner.predictor = self.predictor

    def scanned(self, index: int, emap, accuracy) -> None:
        super().scanned(index, emap, accuracy)
        self.predictor.bind(self._terrain)

    def dug(self, index: int, record, metrics) -> None:
        rows = self.rows(record, self.data.n_digs)
        if rows is None or not len(rows):
            return
        observed = magnitude(rows.forces)
        learned = (float(np.mean(np.abs(magnitude(self.model.predict(rows.samples)) - observed)))
                   if self.predictor.active else math.nan)
        nominal = (float(np.mean(np.abs(magnitude(self.nominal.predict(rows.samples)) - observed)))
                   if self.nominal is not None else math.nan)
        # the peak ratio of the predictions the planner planned with: the learned model's once active,
        # the nominal model's before (whose peaks the learned predictor corrects until then)
        planned_with = self.model if self.predictor.active else self.nominal
        if planned_with is not None:
            peak = float(np.max(magnitude(planned_with.predict(rows.samples))))
            if peak >= self.peak_floor_n:
                self.predictor.add_peak_ratio(float(np.max(observed)) / peak, stalled=record.outcome == "stalled")
        self.model.update(rows.samples, rows.forces)
        self.data = ForceDataset.concat([self.data, rows])
        self.predictor.active = self.predictor.active or self.data.n_digs >= self.min_digs
        self.history.append(DigLearning(index, len(rows), learned, nominal))
        self.say(f"  learned from dig {index}: {len(rows)} samples; error on it before the update "
                 f"{learned:.0f} N learned, {nominal:.0f} N nominal; peak margin {self.predictor.peak_margin:.2f}")
