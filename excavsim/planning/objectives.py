"""The utility of trenching digs and the choice among feasible ones (Singh 1995 §6.1.3, §6.2.3).

An action space planner needs two functions (§3.3): feasibility (:mod:`~excavsim.planning.constraints`,
:mod:`~excavsim.planning.feasibility`) and utility, here. The objective (``PlannerConfig.objective``) is
the swept volume (``volume``), the peak torque ratio (``peak_torque``), the cumulative torque, eq. 43's
integral of the joint torques along the path (``cumulative_torque``), or eq. 44 (``lexicographic``, the
"dictionary" search of §6.2.3 with the swept volume as the necessary criterion J1): J = 0 for digs
sweeping at most ``volume_threshold`` z of the capacity, J = J2 > 0 for the others, J maximized,
where J2 is the auxiliary criterion (``auxiliary``): the least peak torque ratio (J2 = 1 - peak,
positive for every force-feasible dig) or the least cumulative torque (J2 = 1 / cumulative). When
no dig passes z, every J is 0 and eq. 44 does not choose: the largest volume does (a tie-break the
thesis leaves open). A best dig below ``min_volume_fraction`` of the capacity is "no dig": the loop then runs its
pre-planned boundary-following fallback (§7.2, the trenching task's own).
"""

from __future__ import annotations

import numpy as np

from excavsim.config import PlannerConfig
from excavsim.planning.action import step_lengths

OBJECTIVES = ("volume", "peak_torque", "cumulative_torque", "lexicographic")


def torque_sum(torques: np.ndarray) -> np.ndarray:
    """(...,) sum of the absolute joint torques of each sample (..., 3) [N m], 0 where unknown (NaN)."""
    return np.nan_to_num(np.abs(torques)).sum(axis=-1)


def cumulative_torque(torques: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """(...) eq. 43 along paths (..., S, 3): the torque sum of each sample after the first times the
    length of the segment reaching it [N m m]."""
    return (torque_sum(torques)[..., 1:] * step_lengths(poses)).sum(axis=-1)


def choose(feasible: np.ndarray, volume: np.ndarray, peak: np.ndarray, cumulative: np.ndarray,
           cfg: PlannerConfig, capacity: float, *, objective: str | None = None) -> tuple[int | None, float, str]:
    """Apply the objective to the feasible cells (see the module docstring).

    Args:
        feasible: (n,) cells with a dig satisfying every constraint.
        volume, peak, cumulative: (n,) each cell's swept volume [m^3], peak torque ratio and
            cumulative torque (any value where infeasible).
        cfg: the thresholds and the objective; capacity: the bucket's struck capacity [m^3].
        objective: one of ``OBJECTIVES``; None uses ``cfg.objective``.

    Returns:
        The chosen cell's index (None for "no dig"), its utility and the reason, for logs.
    """
    objective = cfg.objective if objective is None else objective
    if not feasible.any():
        return None, 0.0, "no feasible dig"
    vol = np.where(feasible, volume, -np.inf)
    useful = vol >= cfg.min_volume_fraction * capacity
    if not useful.any():
        return None, float(vol.max()), (f"best dig sweeps {1000 * vol.max():.1f} l, below the minimum "
                                        f"{100 * cfg.min_volume_fraction:.0f} % of capacity")
    peak = np.where(useful, peak, np.inf)
    cum = np.where(useful, cumulative, np.inf)
    if objective == "volume":
        c = int(np.argmax(vol))
        return c, float(vol[c]), "max volume"
    if objective == "peak_torque":
        c = int(np.argmin(peak))
        return c, float(-peak[c]), "min peak torque"
    if objective == "cumulative_torque":
        c = int(np.argmin(cum))
        return c, float(-cum[c]), "min cumulative torque"
    enough = vol > cfg.volume_threshold * capacity  # eq. 44: J1 > z
    if enough.any():
        if cfg.auxiliary == "cumulative_torque":
            j2 = np.where(enough, 1.0 / np.maximum(cum, 1e-12), 0.0)
            label = "min cumulative torque"
        else:
            j2 = np.where(enough, 1.0 - peak, 0.0)
            label = "min peak torque"
        c = int(np.argmax(np.where(enough, j2, -np.inf)))
        return c, float(j2[c]), f"volume > {100 * cfg.volume_threshold:.0f} % of capacity, {label}"
    c = int(np.argmax(vol))
    return c, 0.0, f"no dig passes {100 * cfg.volume_threshold:.0f} % of capacity: max volume"
