"""The demo job: one hand-picked trenching dig, run through the episode driver like any other.

Park, scan, then instead of planning, dig the fixed action of :data:`DEMO_ACTION` (enter the flat
sand at k = 2.2 m, penetrate 0.2 m at alpha = 40 deg with rake alpha + epsilon = 50 deg, drag
0.4 m while the rake falls, curl), with the dig script's touch-down, lift-out, dump and park; the
soil settles; a last scan measures the result. Nothing checks the action against the planner's
constraints: it is known to be reachable and within the torque limits in the testbed sand.
``excavsim demo`` prints the dig and the episode summary (soil dug, over- and under-dig against
the ``sand`` trench, the soil volume balance).
"""

from __future__ import annotations

import math
from collections.abc import Callable

from excavsim.handoff.dig import DEMO_ACTION, TrenchAction
from excavsim.handoff.episode import EpisodeObserver, EpisodeResult
from excavsim.tasks.trench.spec import resolve_goal
from excavsim.tasks.trench.digs import ScriptedDigs
from excavsim.tasks.trench.task import run_episode
from excavsim.world.simulation import Simulation

__all__ = ["DEMO_ACTION", "demo_from_configs", "run_demo"]


def run_demo(sim: Simulation, *, seed: int = 0, action: TrenchAction = DEMO_ACTION, goal: str = "sand",
             progress: Callable[[str], None] | None = None,
             observer: EpisodeObserver | None = None) -> EpisodeResult:
    """Dig ``action`` once in ``sim`` through the episode driver (see the module docstring).

    Args:
        sim: the world.
        seed: the episode seed of ``sim`` (the scanner's noise).
        action: the trenching action (k [m], alpha [rad], d1 [m], d2 [m]).
        goal: the trench the result is measured against (a name of ``configs/trenches``).
        progress: called with a line of text per scan and dig.
        observer: sees the episode.
    """
    return run_episode(sim, seed=seed, goal=resolve_goal(goal), dig_budget=1, done_fraction=None,
                       digs=ScriptedDigs([action]), progress=progress, observer=observer)


def demo_from_configs(robot_config: str | None = None, scene_config: str | None = None, *, seed: int = 0,
                      progress: Callable[[str], None] | None = None) -> EpisodeResult:
    """``excavsim demo``: build the world from the configuration files (default ``configs/``) and dig
    :data:`DEMO_ACTION` once, saying what it does first.

    Args:
        robot_config, scene_config: the servo and scene configuration files.
        seed: the episode seed.
        progress: called with the header and a line per scan and dig.
    """
    from excavsim.config import load_robot_config, load_scene_config
    from excavsim.world import simulation  # the class looked up when called, as the command always did

    robot = load_robot_config(robot_config)
    scene = load_scene_config(scene_config)
    k, alpha, d1, d2 = DEMO_ACTION
    if progress:
        progress(f"excavsim demo: one hand-picked dig into {scene.soil} (k {k:.2f} m, alpha "
                 f"{math.degrees(alpha):.0f} deg, d1 {d1:.2f} m, d2 {d2:.2f} m): scan, dig, dump, settle, scan "
                 f"(seed {seed})")
    return run_demo(simulation.Simulation(robot, scene, seed=seed), seed=seed, progress=progress)
