"""What the executed digs taught the planner: failures not to repeat, and where the map claimed soil.

The planner decides on a scanned map and a force model, both approximate; the executor meets the
world. :class:`DigExperience` is the episode's memory of that meeting, at sensor level only (the
execution record and the F/T sensor's weighing of the lifted load, never the world's truth):

* a dig **failed** when it stalled, found no contact at touch-down, timed out, or brought up less
  than ``min_load_m3`` (weighed by the F/T sensor while the bucket was held lifted, at the planner's
  soil density). A failed trenching action excludes its neighbourhood in the planner's grid (within
  ``neighbourhood`` cells along k, alpha and d1); a failed boundary-following dig is skipped by the
  fallback; both until the mapped terrain along the failed path has changed by more than
  ``terrain_change_m`` (soil moved there: the same action on new terrain is a new dig);
* a dig that brought up little soil also leaves a **cut bound**: its edge passed there and found
  (almost) nothing, so the terrain along its path is at most at the edge's height (plus
  ``cut_margin_m``), the lower of the planned and the executed edge: when touch-down found contact
  above the map the executor ran the whole dig up to a centimetre above its plan, and the same
  plan would be shifted the same way (lean clay, end game: 14 such skims in a row, each a new
  action, each weighing nothing). Later maps are clipped to it (:meth:`DigExperience.belief`) until the map
  there rises more than ``terrain_change_m`` above the first map after the dig (soil fell or was
  spilled there). This removes the soil a biased map shows (the scanner's systematic error of a
  centimetre or two, §7.1.2) where the bucket found none, so that the planner stops scraping it.
  Bounds only follow digs that found nothing: after a good dig, soil spilled ahead of a full bucket
  and settling walls refill the cut, and only the next scan shows how much.

* the **torque margin**: the force model is static (eq. 8) and misses what the world adds (speed,
  the bucket's bearing, the load in the curl), so the wrist meets more torque than predicted. The
  ratio of the measured to the predicted peak wrist torque is kept for every planned dig that
  brought the wrist to within ``margin_near`` of its relief limit (for a stall, whose measured peak
  is the limit, the demand is taken ``stall_excess`` above it; digs that stayed well below the limit
  say nothing of the risk), and the planner keeps its predicted torques within the limits divided
  by an upper quantile of those ratios (:meth:`DigExperience.torque_margin`): a peak-aware force
  constraint learned from the residuals where they matter. A margin that leaves no dig is relaxed
  towards 1 by the dig source (the trenching task's planned digs).

Not from the thesis, which plans every dig afresh; it is the loop's answer to "never the same
failing dig planned again blindly". numpy only.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from excavsim.handoff.dig import Dig, ExecutionRecord, TrenchAction
from excavsim.handoff.goal import ArmPlane, SurfaceProfile
from excavsim.handoff.maps import ElevationMap
from excavsim.mechanics.wedge import G_M_S2

FAILURE_KINDS = ("stall", "no contact", "timeout", "simulation failure", "diverged", "little soil")
_WATCH_STEP_M = 0.02  # radial spacing of the samples along a failed path whose terrain is watched


def measured_peak_nm(record: ExecutionRecord) -> np.ndarray:
    """(6,) the largest actuator torques [N m] while the soil loaded the arm (touch-down to lift-out);
    NaN when nothing was recorded then."""
    lo, hi = record.in_soil_window()
    torques = [tau for t, tau in zip(record.times, record.torques) if lo <= t <= hi]
    return np.abs(np.asarray(torques)).max(axis=0) if torques else np.full(6, np.nan)


def failure_kind(record: ExecutionRecord, load_m3: float, min_load_m3: float) -> str | None:
    """What went wrong with a dig, from its record and its weighed load [m^3]; None if nothing did."""
    outcome = record.outcome
    if record.stall is not None or outcome == "stalled":
        return "stall"
    if outcome == "no contact":
        return "no contact"
    if outcome.startswith("timeout"):
        return "timeout"
    if outcome.startswith("simulation failure"):
        return "simulation failure"
    if outcome == "diverged":
        return "diverged"
    if not load_m3 >= min_load_m3:  # NaN (never lifted out) counts as nothing brought up
        return "little soil"
    return None


@dataclasses.dataclass(frozen=True)
class Failure:
    """One failed dig.

    Attributes:
        index: the dig's number in the episode.
        kind: one of :data:`FAILURE_KINDS`.
        dig_kind: the dig's kind ("planned", "fallback: <boundary>", ...).
        action: its trenching action, or None (a boundary-following dig).
        x, z_map: radial samples along its path [m] and the mapped surface there when it failed [m].
        load_m3: the soil it brought up, as weighed [m^3].
    """

    index: int
    kind: str
    dig_kind: str
    action: TrenchAction | None
    x: np.ndarray
    z_map: np.ndarray
    load_m3: float


@dataclasses.dataclass
class CutBound:
    """Where a dig's edge passed and found little soil: the terrain there is at most at the edge.

    Attributes:
        x: (n,) radial bins along the arm plane [m]; z: (n,) the lowest edge height in each [m];
        z_after: (n,) the mapped surface there on the first map after the dig (None until then) [m].
    """

    x: np.ndarray
    z: np.ndarray
    z_after: np.ndarray | None = None


class DigExperience:
    """The episode's memory of its digs (see the module docstring).

    Args:
        min_load_m3: a dig that brings up less is a failure ("little soil") [m^3].
        terrain_change_m: a failure is forgotten, and a cut bound dropped, once the mapped terrain
            along its path has changed by more than this [m].
        neighbourhood: grid cells around a failed action (along each of k, alpha, d1) not planned again.
        cut_margin_m: the bound lies this far above the dig's edge (planned or executed, the lower) [m].
        margin_quantile, margin_max: the torque margin is this quantile of the measured/predicted
            ratios, at most ``margin_max``; margin_min_predicted_nm: digs predicted below this wrist
            torque do not count (their ratio is the bucket's weight, not the soil) [N m];
            margin_near: only digs whose measured wrist peak reached this fraction of its limit count.
        stall_excess: a stalled dig's demand, as a multiple of its measured (relief-limited) peak (tuned).
    """

    def __init__(self, *, min_load_m3: float = 0.001, terrain_change_m: float = 0.03, neighbourhood: int = 1,
                 cut_margin_m: float = 0.005, margin_quantile: float = 0.8, margin_max: float = 2.0,
                 margin_min_predicted_nm: float = 100.0, margin_near: float = 0.9, stall_excess: float = 1.25):
        self.min_load_m3 = float(min_load_m3)
        self.terrain_change_m = float(terrain_change_m)
        self.neighbourhood = int(neighbourhood)
        self.cut_margin_m = float(cut_margin_m)
        self.margin_quantile = float(margin_quantile)
        self.margin_max = float(margin_max)
        self.margin_min_predicted_nm = float(margin_min_predicted_nm)
        self.stall_excess = float(stall_excess)
        self.margin_near = float(margin_near)
        self.torque_ratios: list[float] = []  # measured / predicted peak wrist torque of planned digs
        self.failures: list[Failure] = []
        self.cuts: list[CutBound] = []

    # -- learning -------------------------------------------------------------------------------
    def learn(self, index: int, dig: Dig, record: ExecutionRecord, surface: SurfaceProfile,
              density_kg_m3: float, *, wrist_limit_nm: float = math.inf) -> Failure | None:
        """Remember what dig ``index`` met.

        Args:
            surface: the scanned surface it was planned on (before this memory's corrections).
            density_kg_m3: the soil density the planner assumes, to turn the weighed load into a volume.
            wrist_limit_nm: the wrist pitch's relief limit (for the torque margin) [N m].

        Returns:
            The failure, or None when the dig succeeded.
        """
        load = record.lifted_load_n / (density_kg_m3 * G_M_S2) if math.isfinite(record.lifted_load_n) else 0.0
        kind = failure_kind(record, load, self.min_load_m3)
        predicted = float(dig.predicted_peak_nm[2])
        measured = measured_peak_nm(record)[3]
        near = measured >= self.margin_near * wrist_limit_nm
        if dig.action is not None and predicted >= self.margin_min_predicted_nm and near:
            excess = self.stall_excess if kind == "stall" else 1.0  # a stall's demand lies beyond the limit
            self.torque_ratios.append(excess * measured / predicted)
        x0, x1 = float(dig.poses[:, 0].min()), float(dig.poses[:, 0].max())
        x = np.linspace(x0, x1, max(2, int(math.ceil((x1 - x0) / _WATCH_STEP_M)) + 1))
        if kind is None:
            return None
        if kind == "little soil" and len(record.executed_path) > 1:
            self.cuts.append(self._cut(np.concatenate([np.asarray(record.executed_path)[:, :3], dig.poses[:, :3]])))
        failure = Failure(index, kind, dig.kind, dig.action, x, surface(x), float(load))
        self.failures.append(failure)
        return failure

    @staticmethod
    def _cut(path: np.ndarray) -> CutBound:
        """The lowest edge height in each radial bin along an executed tip path (T, 3)."""
        bins = np.round(path[:, 0] / _WATCH_STEP_M).astype(np.int64)
        keys, inverse = np.unique(bins, return_inverse=True)
        z = np.full(len(keys), np.inf)
        np.minimum.at(z, inverse, path[:, 1])
        return CutBound(keys * _WATCH_STEP_M, z)

    # -- using it -------------------------------------------------------------------------------
    def torque_margin(self) -> float:
        """The factor (>= 1, at most ``margin_max``) by which measured peak wrist torques exceeded the
        predicted ones: the ``margin_quantile`` of the ratios of the planned digs so far (1 before any)."""
        if not self.torque_ratios:
            return 1.0
        return float(np.clip(np.quantile(self.torque_ratios, self.margin_quantile), 1.0, self.margin_max))

    def _unchanged(self, x: np.ndarray, z_then: np.ndarray, surface: SurfaceProfile) -> bool:
        return bool(np.max(np.abs(surface(x) - z_then)) <= self.terrain_change_m)

    def standing(self, surface: SurfaceProfile) -> list[Failure]:
        """The failures whose terrain has not changed since, on the mapped ``surface`` (before bounds)."""
        return [f for f in self.failures if self._unchanged(f.x, f.z_map, surface)]

    def excluded(self, grid_k: np.ndarray, grid_alpha: np.ndarray, grid_d1: np.ndarray,
                 surface: SurfaceProfile) -> np.ndarray:
        """(n_k, n_alpha, n_d1) the planner's cells near a standing failed action, not to be planned."""
        mask = np.zeros((len(grid_k), len(grid_alpha), len(grid_d1)), bool)
        n = self.neighbourhood
        for f in self.standing(surface):
            if f.action is None:
                continue
            i, j, m = (int(np.argmin(np.abs(g - v))) for g, v in ((grid_k, f.action.k), (grid_alpha, f.action.alpha),
                                                                (grid_d1, f.action.d1)))
            mask[max(i - n, 0):i + n + 1, max(j - n, 0):j + n + 1, max(m - n, 0):m + n + 1] = True
        return mask

    def failed_before(self, dig_kind: str, surface: SurfaceProfile) -> bool:
        """Whether a dig of this kind (a boundary dig's label) failed on the same terrain."""
        return any(f.dig_kind == dig_kind for f in self.standing(surface))

    def belief(self, emap: ElevationMap, arm: ArmPlane, waist: float, width: float,
               surface: SurfaceProfile) -> ElevationMap:
        """``emap`` clipped to the standing cut bounds (``surface``: the plane's profile of ``emap``, as
        scanned).

        A bound stands while the map along it has not risen more than ``terrain_change_m`` above the
        first map after its dig; it covers the cells whose centres lie within the bucket's width.
        """
        for c in self.cuts:
            if c.z_after is None:
                c.z_after = surface(c.x)
        self.cuts = [c for c in self.cuts if np.max(surface(c.x) - c.z_after) <= self.terrain_change_m]
        standing = self.cuts
        if not standing:
            return emap
        p0 = arm.plane_to_world(waist, np.zeros(2))
        along = arm.plane_to_world(waist, np.array([1.0, 0.0])) - p0
        along = along[:2] / np.linalg.norm(along[:2])
        xc, yc = emap.centres()
        xx, yy = np.meshgrid(xc - p0[0], yc - p0[1])
        radial = xx * along[0] + yy * along[1]
        lateral = -xx * along[1] + yy * along[0]
        near = np.abs(lateral) <= 0.5 * width
        heights = emap.heights.copy()
        for c in standing:
            on = near & (radial >= c.x[0] - 0.5 * emap.cell) & (radial <= c.x[-1] + 0.5 * emap.cell)
            bound = np.interp(radial[on], c.x, c.z) + self.cut_margin_m
            heights[on] = np.minimum(heights[on], bound)
        return dataclasses.replace(emap, heights=heights)

    def summary(self) -> str:
        """One line: the failures so far by kind, and the cut bounds."""
        kinds = {k: sum(f.kind == k for f in self.failures) for k in FAILURE_KINDS}
        told = ", ".join(f"{v} {k}" for k, v in kinds.items() if v) or "none"
        return f"failed digs: {told}; cut bounds: {len(self.cuts)}; torque margin {self.torque_margin():.2f}"
