"""``excavsim/PitDig-v0``: the pit dug one dig per step, the agent choosing the lane (Gymnasium).

:class:`PitCore` steps the platform's :class:`~excavsim.loop.episode.Episode` of the pit task phase by
phase (the generic dig-level core, :class:`~excavsim.envs.core.DigLevelCore`), with the agent's lane in
place of the dig source's choice: the lane's planner plans the dig on the scanned map (a lane without a
dig of minimum utility gives way to the lane with the most soil that has one, as the task's own source
does). :class:`PitDigEnv` is its Gymnasium face (:class:`~excavsim.envs.dig_env.DigStepEnv`).
"""

from __future__ import annotations

from collections.abc import Mapping
from types import SimpleNamespace
from typing import Any

import gymnasium as gym
import numpy as np

from excavsim.envs.core import DigLevelCore, Field, as_spec, check_weights
from excavsim.envs.dig_env import DigStepEnv
from excavsim.errors import EnvError
from excavsim.loop.scenario import resolve
from excavsim.tasks.pit_digging.digs import LaneDigs, lane_soil_m3
from excavsim.tasks.pit_digging.task import NAME, dig_rows, spec_episode, summary

PIT_WEIGHTS = {"removed_per_l": 1.0, "overdig_per_l": 2.0, "stall": 5.0}
"""The default reward weights (the trench's dig environment's): per litre removed from the pit, per litre dug
below its goal, per stalled dig."""


class PitCore(DigLevelCore):
    """The pit-digging episode, one step per dig; the action is the lane's index (as a vector of one number).

    Observation: ``soil_l`` (the soil the scanned map shows above each lane's goal [l]) and ``digs_left``.
    Reward per dig (true terrain, after settlement): ``removed_per_l`` x litres removed above the pit's goal,
    less ``overdig_per_l`` x litres dug below it, less ``stall`` for a stalled dig. ``terminated`` when the
    episode ends ``done``, ``no_dig`` or ``diverged``; ``truncated`` at the dig budget or the wall-clock limit.
    ``info``: ``lane_used`` and ``dig`` (its row) after a dig, ``reward_terms``, and ``episode`` (the summary
    without wall times) at the end.

    Args:
        spec: the episode: an :class:`~excavsim.loop.scenario.EpisodeSpec` of the task, a mapping of its fields, a
            YAML path, or None (the task's defaults: the small pit).
        weights: reward weights over :data:`PIT_WEIGHTS`.
        observer: an extra observer of the episode (a recorder, say).
    """

    action_label = "the lane"

    def __init__(self, spec=None, *, weights: Mapping[str, float] | None = None, observer=None):
        self.spec = as_spec(spec, NAME)
        self.resolved = resolve(self.spec)
        self.weights = check_weights(weights, PIT_WEIGHTS, "pit")
        self.observer = observer
        n = len(self.resolved.lanes)
        self.action_low, self.action_high = np.zeros(1), np.array([n - 1.0])
        self.fields = {"soil_l": Field((n,), "float32", 0.0, 1e4, doc="soil the map shows above each lane's goal [l]"),
                       "digs_left": Field((), "int64", n=self.spec.dig_budget + 1, doc="digs left in the budget")}
        self._episode, self._closed = None, False
        self._clear()

    def _start(self, seed: int) -> None:
        self._episode = ep = spec_episode(self.spec, self.resolved, observer=self.observer)
        ep.reset(seed, digs=LaneDigs())
        self._sim = ep.sim
        self._litres = self._truth()

    def _truth(self) -> np.ndarray:
        """(removed above the pit's goal, dug below it) so far on the true terrain [l] (privileged: for the reward)."""
        t = self._episode.task
        h, h0, goal = (a[t.mask] for a in (t.sim.soil.grid.heights, t.initial_heights, t.z_goal))
        return 1000 * t.sim.soil.grid.cell_area * np.array([np.clip(h0 - np.maximum(h, goal), 0, None).sum(),
                                                            np.clip(goal - h, 0, None).sum()])

    def _advance(self):
        if not self._episode.over:
            self._episode.look()  # park, scan and the done test: the agent's decision, or the end
        return self._episode  # its ``result`` is None while it runs

    def _agent_choice_for(self, action: np.ndarray):
        ep = self._episode
        return ep.task.source.choose(ep.task.lanes, ep.emap, first=int(round(action[0])))

    def _dig(self) -> None:
        dug = self._episode.dig()
        if dug is None:  # the world failed on the way to the dig
            return
        now = self._truth()
        gained, self._litres = now - self._litres, now
        stalled = dug[1].stall_joint is not None
        w = self.weights
        reward = w["removed_per_l"] * gained[0] - w["overdig_per_l"] * gained[1] - w["stall"] * stalled
        self._last = {"metrics": dug[1], "lane": self._episode.choice.dig.lane, "reward": float(reward),
                      "terms": {"removed_l": float(gained[0]), "overdig_l": float(gained[1]), "stalled": stalled}}

    def _observation(self) -> dict[str, np.ndarray]:
        ep, n = self._episode, len(self.resolved.lanes)
        seen = ep is not None and ep.emap is not None
        soil = 1000 * lane_soil_m3(ep.task.lanes, ep.emap) if seen else np.zeros(n)
        left = self.spec.dig_budget - (ep.digs_done if ep is not None else 0)
        return {"soil_l": soil.astype(np.float32), "digs_left": np.int64(max(left, 0))}

    def _info(self, decision, first: bool = False) -> dict[str, Any]:
        info: dict[str, Any] = {}
        if not first and self._last is not None:
            info.update(lane_used=self._last["lane"], reward_terms=dict(self._last["terms"]),
                        dig=dig_rows(SimpleNamespace(digs=[self._last["metrics"]]))[0])
        if decision.result is not None:
            info["episode"] = {k: v for k, v in summary(decision.result).items() if k != "wall_s"}
        return info


class PitDigEnv(DigStepEnv):
    """A pit-digging episode, one step per dig: the action is the lane to dig (``Discrete(lanes)``).

    See :class:`PitCore` for the observation, the reward and the end. Seeding as the other dig-level
    environments: ``reset(seed=s)`` runs the episode with seed ``s``; ``reset()`` the spec's seed first.

    Args:
        spec, weights, observer: as :class:`PitCore`.
        render_mode: None or ``"rgb_array"`` (a frame of the world between digs).
        render_size: (width, height) of the frames [pixels].
    """

    core_class = PitCore
    env_id = "PitDig-v0"
    action_noun = "lane"

    def __init__(self, spec=None, *, render_mode: str | None = None, render_size: tuple[int, int] = (480, 360),
                 **kwargs: Any):
        super().__init__(spec, render_mode=render_mode, render_size=render_size, **kwargs)
        self.action_space = gym.spaces.Discrete(len(self.core.resolved.lanes))

    def step(self, action):
        """Dig in lane ``action``; returns (observation, reward, terminated, truncated, info)."""
        if not self.action_space.contains(action):
            raise EnvError(f"the lane must be an integer from 0 to {self.action_space.n - 1}; given {action!r}")
        return self.core.step(np.array([int(action)], dtype=float))
