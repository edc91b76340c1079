"""The Rerun recording of a pit episode: the trench recorder's entities, in each dig's lane, and the pit as the goal.

:class:`PitRecorder` is :class:`~excavsim.record.trench.TrenchRecorder` (the T3's bodies, the true and the
scanned terrain, the planned and the executed paths, the feasible set, forces, torques, metrics, log and
summary; see its module for the entity tree) with three changes: the plan and the executed path are
drawn in the arm plane of the lane each dig is in; ``world/goal`` holds the pit's opening and every
lane's goal profile (``world/goal/footprint`` the pit's cells at their goal height); the configuration
and the summary's title name the pit. It imports no Rerun: it draws with the recorder's vocabulary.
"""

from __future__ import annotations

import math

import numpy as np
import yaml

from excavsim.handoff.goal import goal_profile
from excavsim.record.trench import GOAL_RGB, TrenchRecorder


class PitRecorder(TrenchRecorder):
    """Records one pit episode to ``path`` (an ``.rrd`` file), also streaming to the viewer at ``live``.

    Its ``started`` hook takes the pit task's ``reset`` arguments: the world, the rig of the middle lane,
    the pit's mask and goal heights on the soil grid, the lanes' rigs and the pit.
    """

    def begin(self, sim, rig, goal_mask, goal_z, lanes, pit):
        self.lanes, self.pit = lanes, pit
        return super().begin(sim, rig, goal_mask, goal_z)

    def config_text(self) -> str:
        lanes = {"pit": self.pit.model_dump(mode="json"), "lanes": [lane.goal.model_dump(mode="json")
                                                                    for lane in self.lanes]}
        return f"{super().config_text()}\n## The pit and its lanes\n\n```yaml\n{yaml.safe_dump(lanes, sort_keys=False)}```\n"

    def setup(self) -> None:
        super().setup()
        self._title = (f"# Episode: pit {self.pit.name} ({len(self.lanes)} lanes), soil {self.sim.scene.soil}, "
                       f"seed {self.sim.seed}\n\n")
        self._log_summary("No dig yet: the arm parks, the scanner maps the soil, the lane with the most soil is planned.")

    def planned(self, index, plan, dig) -> None:
        if dig is not None:  # the plan and, after it, the executed path lie in the lane's arm plane
            self.rig = self.lanes[dig.lane]
            self.waist = math.radians(self.rig.goal.waist_deg)
        super().planned(index, plan, dig)

    def _log_goal(self) -> None:
        p, arm = self.pit, self.rig.arm
        x0, x1, y0, y1, z = p.near_x_m, p.far_x_m, p.y_min_m, p.y_max_m, p.surface_z_m
        outline = [[[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z], [x0, y0, z]]]
        for lane in self.lanes:
            g = lane.goal
            r = np.linspace(g.near_x_m, g.far_x_m, 50)
            outline.append(arm.plane_to_world(math.radians(g.waist_deg), np.stack([r, goal_profile(g, r)], axis=-1)))
        self.lines("world/goal", outline, colours=GOAL_RGB, radii=0.005,
                   labels=[f"pit {p.name}"] + [lane.goal.name for lane in self.lanes], static=True)
        rows, cols = np.nonzero(self.goal_mask)
        self.points("world/goal/footprint", np.column_stack([*self.sim.soil.grid.xy(rows, cols),
                                                             self.goal_z[rows, cols]]),
                    colours=GOAL_RGB, radii=0.006, static=True)
