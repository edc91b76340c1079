"""Table 7 of Singh 1995 (§7.3) side by side: an episode's per-cycle times beside the Sparc 10's.

:class:`Table7Timer` is an :class:`~excavsim.handoff.episode.EpisodeObserver`: it reads the timing
hooks the loop leaves (``Rig.timings``: the scan's acquisition and map building, the moves' set-up;
``PlanResult.timings``: the feasible set and the selection; the dig's simulated time) and changes
nothing the episode does. ``excavsim trench --timing`` prints :meth:`Table7Timer.table`.

What the rows measure here (the thesis' Table 7 counts a cycle of the real testbed):

* range data acquisition: the wall time of the ``n_scans`` range images (ray casting; the
  Perceptron took 20 s);
* elevation map generation: the wall time of calibration, median filter, binning and filling;
* construction of the feasible action set: the planner's search up to its choice (wall);
* selection: the objective's choice and the chosen dig's path (wall);
* set-up of the digging tool: the simulated seconds of the moves around the dig (park out of the
  scanner's view, go home over the box), and their wall time;
* execution of the digging trajectory: the dig's simulated seconds, and its wall time.
"""

from __future__ import annotations

import time

import numpy as np

from excavsim.handoff.episode import EpisodeObserver

# Table 7: (row, thesis' computing time [s], its estimate for an optimized version [s])
THESIS_TABLE7 = (
    ("range data acquisition", 20.0, 1.0),
    ("elevation map generation", 45.0, 1.0),
    ("construction of feasible action set", 60.0, 30.0),
    ("selection of the plan", 10.0, 10.0),
    ("set up of digging tool", 30.0, 5.0),
    ("execution of digging trajectory", 30.0, 30.0),
)


class Table7Timer(EpisodeObserver):
    """Collects each cycle's Table 7 times from an episode (see the module docstring)."""

    def __init__(self):
        self.rig = None
        self.cycles: list[dict[str, float]] = []
        self._cycle: dict[str, float] = {}
        self._planned_wall = 0.0

    def started(self, sim, rig, goal_mask, goal_z):
        self.rig = rig

    def scanned(self, index, emap, accuracy):
        t = self.rig.timings
        self._cycle = {"acquisition": t.get("acquisition_wall_s", np.nan), "map": t.get("map_wall_s", np.nan),
                       "park_sim": t.get("park_sim_s", np.nan), "park_wall": t.get("park_wall_s", np.nan)}

    def planned(self, index, plan, dig):
        timings = getattr(plan, "timings", None) or {}
        select = timings.get("select_s", 0.0)
        total = dig.planning_s if dig is not None else getattr(plan, "seconds", np.nan)
        self._cycle.update({"feasible": total - select, "select": select})
        self._planned_wall = time.perf_counter()

    def dug(self, index, record, metrics):
        t = self.rig.timings
        wall = time.perf_counter() - self._planned_wall
        self._cycle.update({
            "home_sim": t.get("home_sim_s", np.nan), "execution_sim": metrics.sim_s,
            "setup_wall": t.get("home_wall_s", np.nan) + self._cycle.get("park_wall", np.nan),
            "execution_wall": wall - t.get("home_wall_s", 0.0),
        })
        self.cycles.append(self._cycle)
        self._cycle = {}

    def means(self) -> dict[str, float]:
        """Each quantity's mean over the cycles that dug."""
        keys = sorted({k for c in self.cycles for k in c})
        return {k: float(np.nanmean([c.get(k, np.nan) for c in self.cycles])) for k in keys}

    def table(self) -> str:
        """Table 7 beside this episode's mean per dig cycle."""
        if not self.cycles:
            return "Table 7: no dig cycle to time"
        m = self.means()
        ours = [
            (f"{m['acquisition']:.2f}", "wall: ray casting"),
            (f"{m['map']:.2f}", "wall"),
            (f"{m['feasible']:.2f}", "wall"),
            (f"{m['select']:.3f}", "wall"),
            (f"{m['park_sim'] + m['home_sim']:.1f}", f"simulated (park + home); wall {m['setup_wall']:.2f}"),
            (f"{m['execution_sim']:.1f}", f"simulated; wall {m['execution_wall']:.2f}"),
        ]
        width = max(len(r[0]) for r in THESIS_TABLE7)
        lines = [f"Table 7 (Singh 1995 §7.3), mean per dig cycle over {len(self.cycles)} cycles [s]:",
                 f"  {'function':<{width}}  {'Sparc 10':>8}  {'optimized':>9}  {'excavsim':>8}  what excavsim measures"]
        for (name, sparc, opt), (value, what) in zip(THESIS_TABLE7, ours):
            lines.append(f"  {name:<{width}}  {sparc:>8.0f}  {opt:>9.0f}  {value:>8}  {what}")
        return "\n".join(lines)
