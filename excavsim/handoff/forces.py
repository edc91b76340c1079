"""The force-predictor contract: what the planner asks of any model of the soil's push-back.

The planner's force constraint (Singh 1995 §5.3) takes any object with a ``predict``
method (:class:`ForcePredictor`); the nominal one is the wedge model (eq. 8,
:class:`~excavsim.planning.predictor.WedgePredictor`) with the configured soil, which the world's
soil deliberately differs from. Learned predictors (§5.2, :mod:`excavsim.learning`) plug in too:
besides depth, rake and swept volume, every query carries a :class:`DigContext` with what their
bases (eqs. 15-17) need, namely the tip poses, where each sample lies on its dig (entry ``k``,
approach angle ``alpha``, distance moved along ``d1`` and along ``d2``, Fig. 66) and the mapped
surface the candidates were planned on. The wedge model ignores it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Protocol

import numpy as np

PROGRESS_FIELDS = ("k", "alpha", "s1", "s2")


@dataclasses.dataclass(frozen=True)
class DigContext:
    """Where the samples of one force query lie on their digs (the encoding of Figs. 65-67).

    Attributes:
        poses: (..., 3) tip poses (x, z, pitch) in the arm plane [m, m, rad], the query's shape.
        progress: (..., 4) per sample ``(k, alpha, s1, s2)``: the radial distance where its dig
            enters the surface [m], the dig's approach angle [rad], the distance moved so far along
            the penetration (``d1*`` of Fig. 66) and along the drag (``d2**``) [m]; during the curl
            both stay at the dig's ``d1`` and ``d2``. None when the caller has no trenching action
            (e.g. a boundary-following dig): a learned predictor then infers it from the poses.
        surface: the mapped surface ``z(x)`` along the arm plane that the samples were planned on
            (a :class:`~excavsim.handoff.goal.SurfaceProfile`), or None.
    """

    poses: np.ndarray
    progress: np.ndarray | None = None
    surface: Callable[[np.ndarray], np.ndarray] | None = None


class ForcePredictor(Protocol):
    """Predicts the soil's force on the bucket at samples of a dig (vectorized)."""

    def predict(self, depth: np.ndarray, rake: np.ndarray, volume: np.ndarray,
                context: DigContext | None = None) -> np.ndarray:
        """Force of the soil on the bucket in the arm plane.

        Args:
            depth: (...) depth of the cutting edge below the (mapped) surface [m], >= 0.
            rake: (...) rake (pitch) of the blade [rad].
            volume: (...) soil swept so far along the dig [m^3].
            context: where the samples lie on their digs (see :class:`DigContext`); the planner
                always passes it, predictors that need only depth, rake and volume ignore it.

        Returns:
            (..., 2) force (F_x, F_z) on the bucket [N], x radial (away from the robot), z up. The
            weight of the soil carried in the bucket is not included: the planner adds it.
        """
        ...


def trajectory_progress(poses: np.ndarray, phases, epsilon: float, *, start: np.ndarray | None = None
                        ) -> np.ndarray:
    """``(k, alpha, s1, s2)`` of every sample of planned paths (see :attr:`DigContext.progress`).

    A planned trenching path starts at its entry with the rake ``alpha + epsilon`` (§3.4.2.2), so
    ``k`` and ``alpha`` come from its first pose; ``s1`` and ``s2`` add up the lengths of the
    segments that reach penetrate (phase 0) and drag (phase 1) samples.

    Args:
        poses: (..., S, 3) paths of S samples (x, z, pitch) [m, m, rad].
        phases: (S,) or broadcastable to (..., S): 0 penetrate, 1 drag, 2 curl.
        epsilon: the planner's rake offset during penetration [rad].
        start: (..., 4) progress at the first sample when the paths continue earlier ones (a drag
            from the end of its penetration, a curl from the end of its drag); None for paths
            that start at their entry.

    Returns:
        (..., S, 4) progress.
    """
    poses = np.asarray(poses, dtype=float)
    out = np.zeros(poses.shape[:-1] + (4,))
    phases = np.asarray(phases)
    for phase, col in ((0, 2), (1, 3)):  # a single-phase path (the planner's usual query) skips the other
        if phases.ndim == 0 and int(phases) != phase:
            continue
        seg = np.hypot(np.diff(poses[..., 0], axis=-1), np.diff(poses[..., 1], axis=-1))
        if phases.ndim:
            seg = np.where(np.broadcast_to(phases, poses.shape[:-1])[..., 1:] == phase, seg, 0.0)
        np.cumsum(seg, axis=-1, out=out[..., 1:, col])
    if start is None:
        out[..., 0] = poses[..., :1, 0]
        out[..., 1] = poses[..., :1, 2] - epsilon
    else:
        out += np.asarray(start, dtype=float)[..., None, :] * np.array([0.0, 0.0, 1.0, 1.0])
        out[..., :2] = np.asarray(start, dtype=float)[..., None, :2]
    return out
