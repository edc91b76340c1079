"""The pit's dig source: each cycle, a planned dig in the lane where the map shows the most soil.

:class:`LaneDigs` ranks the lanes by the soil the scanned map shows above each lane's goal (sampled as
the lane's planner sees the terrain: the map along its arm plane, averaged across the bucket), and asks
the lanes' planners in that order (Singh 1995 ch. 6: the trench planner, one per lane) for a dig of
minimum utility; the first lane that has one digs. Each lane keeps a memory of its failed digs
(:class:`~excavsim.planning.experience.DigExperience`), so that a dig that failed is not planned again
on unchanged terrain. The environment (:mod:`~excavsim.tasks.pit_digging.env`) asks for the agent's lane first.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from excavsim.handoff.dig import Dig
from excavsim.handoff.goal import goal_profile
from excavsim.handoff.maps import ElevationMap
from excavsim.loop.digs import Choice, DigSource
from excavsim.planning.experience import DigExperience
from excavsim.rig.core import Rig


@dataclasses.dataclass(frozen=True)
class LaneDig(Dig):
    """A planned dig in lane ``lane`` (an index of the task's lanes)."""

    lane: int = 0


def lane_soil_m3(lanes: Sequence[Rig], emap: ElevationMap) -> np.ndarray:
    """(n,) the soil ``emap`` shows above each lane's goal profile, in its bucket-wide strip [m^3]."""
    soil = []
    for rig in lanes:
        goal, surface = rig.goal, rig.planner.surface(emap)
        inside = (surface.x >= goal.near_x_m) & (surface.x <= goal.far_x_m)
        above = np.clip(surface.z - goal_profile(goal, surface.x), 0, None)[inside]
        soil.append(float(above.sum() * (surface.x[1] - surface.x[0]) * rig.width))
    return np.array(soil)


class LaneDigs(DigSource):
    """The planner's dig in the lane with the most soil on the map (see the module docstring).

    The ``rig`` its hooks are given is the task's list of lanes (a :class:`~excavsim.rig.core.Rig` each,
    with the lane's goal and planner).
    """

    def __init__(self):
        self.experience: dict[int, DigExperience] = {}

    def choose(self, lanes: Sequence[Rig], emap: ElevationMap, first: int | None = None) -> Choice:
        """The cycle's dig: the lanes by soil on the map, lane ``first`` before them when given."""
        order = [int(i) for i in np.argsort(-lane_soil_m3(lanes, emap), kind="stable")]
        if first is not None:
            order = [first] + [i for i in order if i != first]
        seconds, why = 0.0, []
        for i in order:
            planner = lanes[i].planner
            memory = self.experience.setdefault(i, DigExperience())
            plan = planner.plan(emap, exclude=memory.excluded(planner.grid_k, planner.grid_alpha, planner.grid_d1,
                                                              planner.surface(emap)))
            seconds += plan.seconds
            if plan.action is not None:
                return Choice(LaneDig(f"lane {i + 1}", plan.poses, plan.phases, plan.volume_m3, plan.action, seconds,
                                      predicted_peak_nm=np.abs(plan.torques).max(axis=0), lane=i), plan=plan)
            why.append(f"lane {i + 1}: {plan.reason}")
        return Choice(None, "no lane has a dig of minimum utility (" + "; ".join(why) + ")", plan)

    def learned(self, lanes: Sequence[Rig], index: int, dig: LaneDig, record, emap: ElevationMap) -> str | None:
        planner = lanes[dig.lane].planner
        failure = self.experience[dig.lane].learn(index, dig, record, planner.surface(emap), planner.density,
                                                  wrist_limit_nm=float(planner.limits[2]))
        if failure is None:
            return None
        return f"  learned: {failure.kind} in lane {dig.lane + 1}; that dig is not planned again until the terrain changes"
