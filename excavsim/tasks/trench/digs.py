"""Trenching's dig sources: the planner (with its fallback), a random feasible dig, or a script.

The trenching task (:class:`~excavsim.tasks.trench.task.TrenchTask`) asks a
:class:`~excavsim.loop.digs.DigSource` for one dig per cycle, on the map it just scanned, and tells
it afterwards how the dig went:

* :class:`PlannedDigs` (the default): the planner's choice (Singh 1995 ch. 6), or,
  when its best dig is below the minimum utility, the boundary-following fallback of §7.2; with a
  :class:`~excavsim.planning.experience.DigExperience` it plans on the map as the executed digs
  corrected it and never repeats a failed dig on unchanged terrain;
* :class:`RandomFeasibleDigs`: a seeded random dig of the planner's feasible set that sweeps enough
  soil, so that force data cover the action space (§5.2.4; what ``excavsim learn`` digs);
* :class:`ScriptedDigs`: given trenching actions, one per cycle (``excavsim demo``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from excavsim.handoff.dig import Dig, ExecutionRecord, TrenchAction
from excavsim.handoff.maps import ElevationMap
from excavsim.loop.digs import Choice, DigSource
from excavsim.planning.experience import DigExperience, Failure
from excavsim.rig.core import Rig
from excavsim.tasks.trench.mind import fallback


def predicted_peaks(rig: Rig, poses: np.ndarray, phases: np.ndarray, emap: ElevationMap) -> np.ndarray:
    """(3,) the planner's largest predicted static torque along a trenching path [N m]."""
    _, torques = rig.planner.path_loads(poses, phases, rig.planner.surface(emap))
    return np.abs(torques).max(axis=0)


def relaxed_margins(margin: float, steps: int = 3) -> list[float]:
    """The torque margins to plan with, in order: the learned ``margin``, then closer to 1 by halves
    of the excess, then 1 (the nominal force constraint).

    The margin is an upper quantile of how far measured peaks exceeded predicted ones; a few stalls
    in a hard soil can raise it until no dig of the action space passes, although the trench is far
    from done. Rather than end the episode there, the planner asks for the largest margin that
    still leaves a dig of minimum utility: the safest dig there is, not no dig.
    """
    if margin <= 1.0:
        return [1.0]
    return [1.0 + (margin - 1.0) * 0.5 ** i for i in range(steps)] + [1.0]


# the torque margins (below 1: the limits times 1.1, 1.25, 1.5) within which the planner looks for the
# dig a learned model predicts least over the limits, when it leaves none within them
OVER_LIMIT_MARGINS = (1 / 1.1, 1 / 1.25, 1 / 1.5)


class PlannedDigs(DigSource):
    """The planner's dig, or the boundary-following fallback (§7.2) when none reaches the minimum utility.

    Args:
        experience: the episode's memory of its digs; None plans every cycle afresh, as the thesis does.
    """

    def __init__(self, experience: DigExperience | None = None):
        self.experience = experience
        self._surface = None  # the scanned map's profile this cycle (before the experience's bounds)

    def belief(self, rig: Rig, emap: ElevationMap) -> ElevationMap:
        if self.experience is None:
            return emap
        self._surface = rig.planner.surface(emap)
        return self.experience.belief(emap, rig.arm, math.radians(rig.goal.waist_deg), rig.width, self._surface)

    def choose(self, rig: Rig, emap: ElevationMap) -> Choice:
        choice = self._choose(rig, emap)
        predictor = rig.planner.predictor
        if choice.dig is None and getattr(predictor, "active", False) and hasattr(predictor, "nominal_answers"):
            # A learned model fitted to the digs of a hard soil can predict every dig of minimum
            # utility over the torque limits. It is more often right than the nominal model, which
            # under-predicts that soil: first the dig it predicts least over the limits.
            over = self._choose(rig, emap, margins=OVER_LIMIT_MARGINS, boundary_digs=False)
            if over.dig is not None:
                line = (f"  planner: the learned force model leaves no dig within the torque limits ({choice.reason}); "
                        f"planned the dig it predicts least over them")
                return dataclasses.replace(over, note="\n".join(n for n in (line, over.note) if n))
            # A learned model fitted to a few digs can extrapolate forces that forbid every dig,
            # boundary digs included, where the nominal model still finds one: the prior answers.
            with predictor.nominal_answers():
                prior = self._choose(rig, emap)
            if prior.dig is not None:
                line = f"  planner: the learned force model leaves no dig ({choice.reason}); the nominal model planned"
                return dataclasses.replace(prior, note="\n".join(n for n in (line, prior.note) if n))
        return choice

    def _choose(self, rig: Rig, emap: ElevationMap, margins: Sequence[float] | None = None,
                boundary_digs: bool = True) -> Choice:
        """The plan within the first of ``margins`` that leaves a dig (default: the learned margin
        relaxed towards 1, :func:`relaxed_margins`), else (with ``boundary_digs``) a boundary dig."""
        planner, exp = rig.planner, self.experience
        surface = self._surface if self._surface is not None else planner.surface(emap)
        exclude = exp.excluded(planner.grid_k, planner.grid_alpha, planner.grid_d1, surface) if exp else None
        # the memory's margin (measured over predicted wrist peaks) or the learned predictor's own
        # peak margin (observed over predicted peak forces), whichever is larger
        margin = max(exp.torque_margin() if exp else 1.0, float(getattr(planner.predictor, "peak_margin", 1.0)))
        if margins is None:
            margins = relaxed_margins(margin)
        seconds = 0.0
        for m in margins:
            plan = planner.plan(emap, exclude=exclude, torque_margin=m)
            seconds += plan.seconds
            if plan.action is not None:
                break
        if plan.action is not None:
            peaks = np.abs(plan.torques).max(axis=0)
            if m < 1.0:
                note = f"  planner: planned within the torque limits x {1 / m:.2f}"
            elif m < margin:
                note = (f"  planner: the torque margin {margin:.2f} leaves no dig of minimum utility; "
                        f"planned within {m:.2f}")
            else:
                note = ""
            return Choice(Dig("planned", plan.poses, plan.phases, plan.volume_m3, plan.action, seconds,
                              predicted_peak_nm=peaks), plan=plan, note=note)
        if not boundary_digs:
            return Choice(None, f"no dig of minimum utility ({plan.reason})", plan)
        skip = (lambda d: exp.failed_before("fallback: " + d.label, surface)) if exp else None
        boundary, why = fallback.choose_boundary(planner, emap, skip=skip)
        if boundary is None:
            return Choice(None, f"no dig of minimum utility ({plan.reason}), and no fallback: {why}", plan)
        dig = Dig("fallback: " + boundary.label, boundary.poses, boundary.phases, boundary.volume_m3, None,
                  seconds + boundary.seconds, shift_up=False, predicted_peak_nm=boundary.peak_torques_nm)
        return Choice(dig, plan=plan, note=f"  planner: {plan.reason}; falling back to a {why}")

    def learned(self, rig: Rig, index: int, dig: Dig, record: ExecutionRecord, emap: ElevationMap) -> str | None:
        if self.experience is None:
            return None
        surface = self._surface if self._surface is not None else rig.planner.surface(emap)
        failure: Failure | None = self.experience.learn(index, dig, record, surface, rig.planner.density,
                                                        wrist_limit_nm=float(rig.planner.limits[2]))
        if failure is None:
            return None
        what = "its neighbourhood" if failure.action is not None else "this boundary dig"
        bound = "; the map along its path is clipped to the edge's height" if failure.kind == "little soil" else ""
        return f"  learned: {failure.kind} ({1000 * failure.load_m3:.1f} l weighed): {what} is not planned again " \
               f"until the terrain there changes{bound}"


class RandomFeasibleDigs(DigSource):
    """A random dig of the planner's feasible set sweeping at least ``min_volume_fraction`` of the
    bucket (instead of the planner's choice), so that the digs cover the action space.

    Args:
        rng: the generator that picks the cells (seeded by the caller).
        min_volume_fraction: smallest swept volume, as a fraction of the bucket's capacity.
    """

    def __init__(self, rng: np.random.Generator, min_volume_fraction: float = 0.3):
        self.rng = rng
        self.min_volume_fraction = float(min_volume_fraction)

    def choose(self, rig: Rig, emap: ElevationMap) -> Choice:
        plan = rig.planner.plan(emap)
        enough = plan.feasible & (np.nan_to_num(plan.volume) >= self.min_volume_fraction * rig.capacity)
        cells = np.argwhere(enough)
        if len(cells) == 0:
            return Choice(None, f"no feasible dig sweeping {100 * self.min_volume_fraction:.0f} % of the bucket", plan)
        c = tuple(cells[self.rng.integers(len(cells))])
        action = TrenchAction(float(plan.grid_k[c[0]]), float(plan.grid_alpha[c[1]]), float(plan.grid_d1[c[2]]),
                              float(plan.d2[c]))
        poses, phases = rig.planner.trajectory(action, rig.planner.surface(emap))
        return Choice(Dig("random feasible", poses, phases, float(plan.volume[c]), action, plan.seconds,
                          predicted_peak_nm=predicted_peaks(rig, poses, phases, emap)), plan=plan)


class ScriptedDigs(DigSource):
    """The given trenching actions, one per cycle, each with the planner's trajectory rules (§3.4)
    and without its constraints: the caller vouches for them (an unreachable path stalls or fails
    in the executor, as it would on the machine).

    Args:
        actions: (k [m], alpha [rad], d1 [m], d2 [m]) per dig; the episode ends when they run out.
    """

    def __init__(self, actions: Sequence[tuple[float, float, float, float]]):
        self.actions = [TrenchAction(*map(float, a)) for a in actions]
        self._next = 0

    def choose(self, rig: Rig, emap: ElevationMap) -> Choice:
        if self._next >= len(self.actions):
            return Choice(None, f"all {len(self.actions)} scripted digs done")
        action = self.actions[self._next]
        self._next += 1
        surface = rig.planner.surface(emap)
        poses, phases = rig.planner.trajectory(action, surface)
        swept = rig.planner.swept_volume(poses, surface)
        return Choice(Dig("scripted", poses, phases, swept, action, 0.0,
                          predicted_peak_nm=predicted_peaks(rig, poses, phases, emap)))

