"""A learned force model as the planner's force predictor (000_a3ca905d8c6d92bf.txt §5.3 with §5.2).

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
from collections.abc import Iterator

import numpy as np

from excavsim.errors import ExcavsimError
from excavsim.handoff.forces import DigContext, ForcePredictor
from excavsim.learning.encoding import Terrain, encode, infer_progress
from excavsim.learning.predictors import ForceModel
from excavsim.mechanics.wedge import G_M_S2, tip_to_plane


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
        self.peak_quantile = peak_quantile
        self.peak_max = float(peak_max)
        self._from_surface: tuple[object, Terrain] | None = None

    @property
    def peak_margin(self) -> float:
        """The factor (>= 1, at most ``peak_max``) by which observed peak forces exceeded the model's
        predicted ones: the ``peak_quantile`` of the per-dig ratios of the model that answers (the
        learned one, or the nominal one before it is active; 1 before any ratio)."""
        ratios = self.peak_ratios if (self.active and self.model.fitted) else self.nominal_peak_ratios
        if self.peak_quantile is None or not ratios:
            return 1.0
        return float(np.clip(np.quantile(ratios, self.peak_quantile), 1.0, self.peak_max))

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
            raise ExcavsimError("a learned force predictor needs the terrain: bind() the scanned map's Terrain, or "
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
                raise ExcavsimError("a learned force predictor without a fitted model (or queried without a "
                                    "DigContext) needs a nominal predictor to fall back on")
            return self.nominal.predict(depth, rake, volume, context)
        samples = self.samples(volume, context)
        f_tip = self.model.predict(samples)
        rho = samples["rake"]
        fx, fz = tip_to_plane(f_tip[..., 0], f_tip[..., 1], rho)
        load = self.density * G_M_S2 * np.maximum(samples["v"], 0.0)
        return np.stack([fx, fz + load], axis=-1)
