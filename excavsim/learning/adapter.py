"""A learned force model as the planner's force predictor (Singh 1995 §5.3 with §5.2).

:class:`LearnedForcePredictor` satisfies :class:`~excavsim.planning.predictor.ForcePredictor`:
the planner's force constraint queries it along every candidate dig with a
:class:`~excavsim.planning.predictor.DigContext`, from which it encodes the samples exactly as the
training rows were encoded (:func:`~excavsim.learning.encoding.encode`), predicts what the wrist
sensor would read, and hands the planner the soil's force in the arm plane.

Two conversions: the model predicts tip-frame forces and the planner wants the arm plane
(:func:`~excavsim.world.wedge.tip_to_plane`); and the sensor also weighs the soil carried in the
bucket, which the planner adds itself at the load's centre of mass, so that weight (``rho g v``
with the planner's density) is taken out.

Terrain: the across-trench depths ``c_1``, ``c_3`` need the elevation map, not just the planner's
surface along the trench; :meth:`LearnedForcePredictor.bind` gives it the map's
:class:`~excavsim.learning.encoding.Terrain` (the online observer does so after every scan). When
the bound terrain is not the surface of the query, the query's surface is used, with the
across-trench elevations equal to it.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator

import numpy as np

from excavsim.errors import ConfigError, UsageError
from excavsim.handoff.forces import DigContext, ForcePredictor
from excavsim.learning.encoding import Terrain, encode, infer_progress
from excavsim.learning.predictors import ForceModel
from excavsim.mechanics.wedge import G_M_S2, tip_to_plane


def censored_quantile(values: np.ndarray, censored: np.ndarray, q: float) -> float:
    """The ``q`` quantile of a sample some of whose values are right-censored (only known to be at
    least the value given), from the Kaplan-Meier estimate of its distribution.

    The estimate steps down only at exact values: ``S(t) = prod_{exact t_i <= t} (1 - d_i / n_i)``
    with ``n_i`` the values not below ``t_i`` (a censored value tied with an exact one counts as
    still at risk). The quantile is the smallest exact value where ``1 - S >= q``; ``inf`` when the
    censored values leave the estimate above ``1 - q`` (the sample does not bound that quantile).
    Without censored values it is the lower empirical quantile (``numpy.quantile`` with
    ``method="inverted_cdf"``).
    """
    values = np.asarray(values, dtype=float)
    censored = np.asarray(censored, dtype=bool)
    if values.shape != censored.shape or values.ndim != 1:
        raise UsageError(f"censored_quantile: values {values.shape} and censored {censored.shape} must be "
                         "one-dimensional and of one length")
    if not 0.0 < q < 1.0:
        raise ConfigError(f"censored_quantile: q = {q} must lie in (0, 1)")
    survival = 1.0
    for t in np.unique(values[~censored]):
        at_risk = int(np.count_nonzero(values >= t))
        events = int(np.count_nonzero((values == t) & ~censored))
        survival *= 1.0 - events / at_risk
        if 1.0 - survival >= q - 1e-12:
            return float(t)
    return math.inf


class LearnedForcePredictor:
    """The planner's :class:`~excavsim.planning.predictor.ForcePredictor` over a learned model.

    Args:
        model: the learned model (fitted, or to be fitted later: until then ``nominal`` answers).
        density_kg_m3: the planner's soil density (the weight of the carried load it adds itself).
        epsilon_rad: the planner's rake offset during penetration (to read ``alpha`` off paths that
            come without progress).
        nominal: the predictor used while ``model`` is not fitted (the nominal wedge model).
        peak_quantile, peak_max: :attr:`peak_margin` is this quantile of the per-dig peak ratios, at
            most ``peak_max`` (``peak_quantile=None``: no peak margin, the mean model alone).
    """

    def __init__(self, model: ForceModel, *, density_kg_m3: float, epsilon_rad: float,
                 nominal: ForcePredictor | None = None, peak_quantile: float | None = 0.8,
                 peak_max: float = 2.0):
        self.model = model
        self.density = float(density_kg_m3)
        self.epsilon = float(epsilon_rad)
        self.nominal = nominal
        self.terrain: Terrain | None = None
        self.active = True  # False: the nominal predictor answers (e.g. until the model has seen enough digs)
        self.peak_ratios: list[float] = []  # per dig: observed over the model's predicted peak |F|, out of sample
        self.nominal_peak_ratios: list[float] = []  # the same for the digs planned while the nominal answered
        # per ratio: True when its dig stalled, so that the observed peak is a lower bound (right-censored)
        self.peak_censored: list[bool] = []
        self.nominal_peak_censored: list[bool] = []
        self.peak_quantile = peak_quantile
        self.peak_max = float(peak_max)
        self._from_surface: tuple[object, Terrain] | None = None

    def add_peak_ratio(self, ratio: float, *, stalled: bool = False) -> None:
        """Remember one dig's observed over predicted peak |F|, for the model that planned it (the
        learned one once active, else the nominal one). ``stalled``: the executor stopped the dig at a
        torque limit, so the force would have risen further and the ratio is only a lower bound."""
        learned = self.active and self.model.fitted
        (self.peak_ratios if learned else self.nominal_peak_ratios).append(float(ratio))
        (self.peak_censored if learned else self.nominal_peak_censored).append(bool(stalled))

    @property
    def peak_margin(self) -> float:
        """The factor (>= 1, at most ``peak_max``) by which observed peak forces exceeded the model's
        predicted ones: the ``peak_quantile`` of the per-dig ratios of the model that answers (the
        learned one, or the nominal one before it is active; 1 before any ratio).

        A stalled dig's ratio is right-censored (the true peak was higher than the one measured when
        the executor stopped), so the quantile is the Kaplan-Meier one (:func:`censored_quantile`):
        counting a stall's ratio as exact would put the margin below the peaks that stall."""
        learned = self.active and self.model.fitted
        ratios = self.peak_ratios if learned else self.nominal_peak_ratios
        censored = self.peak_censored if learned else self.nominal_peak_censored
        if self.peak_quantile is None or not ratios:
            return 1.0
        flags = list(censored) + [False] * (len(ratios) - len(censored))  # ratios added without a flag: exact
        q = censored_quantile(np.asarray(ratios, dtype=float), np.asarray(flags[:len(ratios)], dtype=bool),
                              self.peak_quantile)
        return float(np.clip(q, 1.0, self.peak_max))

    @contextlib.contextmanager
    def nominal_answers(self) -> Iterator[None]:
        """Within the block, the nominal predictor answers (with its own peak margin), as before the
        learned model was active; e.g. when the learned model forbids every dig."""
        was = self.active
        self.active = False
        try:
            yield
        finally:
            self.active = was

    def bind(self, terrain: Terrain | None) -> None:
        """The terrain of the map the planner is about to plan on (None to forget it)."""
        self.terrain = terrain

    def _terrain(self, surface) -> Terrain:
        if self.terrain is not None and (surface is None or self.terrain.matches(surface)):
            return self.terrain
        if surface is None:
            raise UsageError("a learned force predictor needs the terrain: bind() the scanned map's Terrain, or "
                             "query it with a DigContext that carries the planner's surface")
        if self._from_surface is None or self._from_surface[0] is not surface:
            self._from_surface = (surface, Terrain.from_surface(surface))
        return self._from_surface[1]

    def samples(self, volume: np.ndarray, context: DigContext) -> dict[str, np.ndarray]:
        """The encoded samples of a query (its shape ``(...)``)."""
        poses = np.asarray(context.poses, dtype=float)
        progress = context.progress if context.progress is not None else infer_progress(poses, self.epsilon)
        progress = np.broadcast_to(progress, poses.shape[:-1] + (4,))
        volume = np.broadcast_to(np.asarray(volume, dtype=float), poses.shape[:-1])
        return encode(poses, progress, volume, self._terrain(context.surface))

    def predict(self, depth: np.ndarray, rake: np.ndarray, volume: np.ndarray,
                context: DigContext | None = None) -> np.ndarray:
        """Soil force (..., 2) in the arm plane [N], x radial, z up, without the carried load's weight."""
        if not (self.active and self.model.fitted) or context is None:
            if self.nominal is None:
                raise UsageError("a learned force predictor without a fitted model (or queried without a "
                                 "DigContext) needs a nominal predictor to fall back on")
            return self.nominal.predict(depth, rake, volume, context)
        samples = self.samples(volume, context)
        f_tip = self.model.predict(samples)
        rho = samples["rake"]
        fx, fz = tip_to_plane(f_tip[..., 0], f_tip[..., 1], rho)
        load = self.density * G_M_S2 * np.maximum(samples["v"], 0.0)
        return np.stack([fx, fz + load], axis=-1)
