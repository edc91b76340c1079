"""excavsim: an open MuJoCo testbed for robotic trenching.

A simulated T3 hydraulic arm with an excavator bucket digs trenches in a heightfield soil box in a
closed scan-plan-dig loop (Singh 1995). See README.md and docs/architecture.md.

Subpackages follow the architecture: ``world`` is the truth (MuJoCo + soil), ``robot`` the arm's
kinematics and statics, ``sensing``/``planning``/``learning``/``execution`` the robot's mind,
``loop`` wires them, ``envs`` offers them as Gymnasium and dm_env environments, ``record`` observes;
``handoff`` holds the values passed between them and ``mechanics`` the soil mechanics the world and
the mind share.

The common path is exported here, imported on first use so that ``import excavsim`` stays light:

* an episode from a specification: :class:`EpisodeSpec`, :func:`load_spec`, :func:`run_spec`, then
  :func:`episode_summary` (a flat dict of numbers), :func:`dig_rows` (one dict per dig) or
  :func:`format_episode` (the table ``excavsim trench`` prints);
* a world and the loop's pieces: :class:`Simulation`, :func:`make_rig` (the planner, executor,
  scanner and the arm's model), :func:`scan` (an elevation map), :func:`resolve` (the configurations a spec stands for);
* planning on a map: :class:`TrenchPlanner` (``rig.planner.plan(emap)``), :class:`ElevationMap`,
  :class:`TrenchAction`.
"""

import importlib
import os

# Headless always: dm_control reads MUJOCO_GL when first imported and would otherwise try a window.
os.environ.setdefault("MUJOCO_GL", "disable")

from excavsim.errors import (ConfigError, DataFileError, DependencyError, Diverged, EnvError,  # noqa: E402
                             ExcavsimError, GoalError, ModelError, OutOfTime, SoilModelError, UsageError, WedgeError,
                             WorldError)

__version__ = "0.1.0"

_LAZY = {
    "EpisodeSpec": "excavsim.loop.scenario",
    "load_spec": "excavsim.loop.scenario",
    "run_spec": "excavsim.loop.scenario",
    "episode_summary": "excavsim.loop.scenario",
    "dig_rows": "excavsim.loop.scenario",
    "resolve": "excavsim.loop.scenario",
    "format_episode": "excavsim.handoff.episode",
    "EpisodeResult": "excavsim.handoff.episode",
    "Simulation": "excavsim.world.simulation",
    "make_rig": "excavsim.rig.core",
    "scan": "excavsim.rig.core",
    "TrenchPlanner": "excavsim.planning.search",
    "PlanResult": "excavsim.planning.search",
    "ElevationMap": "excavsim.handoff.maps",
    "TrenchAction": "excavsim.handoff.dig",
}

ERRORS = ["ConfigError", "DataFileError", "DependencyError", "Diverged", "EnvError", "ExcavsimError", "GoalError",
          "ModelError", "OutOfTime", "SoilModelError", "UsageError", "WedgeError", "WorldError"]  # excavsim.errors
__all__ = [*ERRORS, "__version__", *_LAZY]


def __getattr__(name: str):
    """The exports of the common path, imported when first asked for (see the module docstring)."""
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'excavsim' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
