"""Force samples from the digs of an episode: the tip's trace, the terrain of each scan, the rows.

:class:`DigSamples` is an episode observer: it traces the tip from the joint encoders, keeps the
terrain of each scan and the phases of each chosen dig, and turns a dig's execution record into
force samples (:func:`~excavsim.learning.dataset.samples_from_record`, the encoding of
Singh 1995 §5.2.2). Collecting data (:mod:`excavsim.studies.learning.collect`) and learning
online (:mod:`excavsim.rig.online`) both build on it.
"""

from __future__ import annotations

import math

import numpy as np

from excavsim.handoff.episode import EpisodeObserver
from excavsim.learning.dataset import ForceDataset, samples_from_record
from excavsim.learning.encoding import Terrain
from excavsim.robot.kinematics import PlanarArm


class TipTrace:
    """The tip pose after every control step, from the joint encoders (a ``Simulation`` step hook).

    Reads the joint angles only: never the F/T noise stream, so that tracing does not change the
    episode.
    """

    def __init__(self, arm: PlanarArm):
        self.arm = arm
        self.clear()

    def __call__(self, sim) -> None:
        self._t.append(sim.time)
        self._q.append(sim.joint_angles()[1:4])

    def clear(self) -> None:
        self._t: list[float] = []
        self._q: list[np.ndarray] = []

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """Times (T,) [s] and tip poses (T, 3) (x, z, pitch) [m, m, rad]."""
        if not self._t:
            return np.zeros(0), np.zeros((0, 3))
        return np.asarray(self._t), self.arm.forward(np.asarray(self._q))


class DigSamples(EpisodeObserver):
    """Turns every dig of an episode into force samples (the encoding of §5.2.2).

    It traces the tip through the episode, keeps the terrain of each scan (the map the dig was
    planned on, never the truth) and the phases of each chosen dig; after a dig, :meth:`rows` gives
    its samples. Subclasses (the online learner) or callers use them.
    """

    def started(self, sim, rig, goal_mask, goal_z) -> None:
        self.rig = rig
        self.trace = TipTrace(rig.arm)
        self.waist = math.radians(rig.goal.waist_deg)
        self.epsilon = math.radians(rig.planner_cfg.epsilon_deg)
        self._terrain: Terrain | None = None
        self._phases = None

    def scanned(self, index: int, emap, accuracy) -> None:
        self._terrain = Terrain.from_map(emap, self.rig.arm, self.waist, self.rig.width)

    def planned(self, index: int, plan, dig) -> None:
        self._phases = None if dig is None else dig.phases
        self.trace.clear()

    def stepped(self, sim) -> None:
        self.trace(sim)

    def rows(self, record, dig_number: int) -> ForceDataset | None:
        """The samples of the dig just executed, numbered ``dig_number`` (None without a trace)."""
        t, tip = self.trace.arrays()
        self.trace.clear()
        if self._phases is None or self._terrain is None or len(t) < 2:
            return None
        return samples_from_record(record, trace_times=t, trace_poses=tip, terrain=self._terrain,
                                   phases=self._phases, epsilon=self.epsilon, width=self.rig.width, dig=dig_number)
