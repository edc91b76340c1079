"""Reinforcement-learning environments on the trenching testbed, at two levels.

* ``excavsim/TrenchDig-v0`` (:class:`~excavsim.envs.dig_env.TrenchDigEnv`): one step per dig, the
  action Singh's trenching action (k, alpha, d1); the episode is the loop of ``excavsim trench``
  with the agent in the planner's place.
* ``excavsim/TrenchJoint-v0`` (:class:`~excavsim.envs.joint_env.TrenchJointEnv`): one step per
  control period, the action the servos' set-point rates.

Importing this module registers both with Gymnasium (``gymnasium.make("excavsim/TrenchDig-v0",
spec=...)``; install ``excavsim[envs]``). :mod:`excavsim.envs.dm` has the same environments with a
dm_env face (:class:`~excavsim.envs.dm.DmTrenchDig`, :class:`~excavsim.envs.dm.DmTrenchJoint`), which
needs only dm-env. The cores (:mod:`excavsim.envs.core`, :mod:`excavsim.envs.joint_core`) know neither library.
"""

from __future__ import annotations

from excavsim.envs.core import DIG_WEIGHTS, OUTCOMES, DigCore, EnvError
from excavsim.envs.joint_core import JOINT_WEIGHTS, JointCore

__all__ = ["DIG_WEIGHTS", "DIG_ENV_ID", "JOINT_ENV_ID", "JOINT_WEIGHTS", "OUTCOMES", "DigCore", "EnvError",
           "JointCore", "register"]

DIG_ENV_ID = "excavsim/TrenchDig-v0"
JOINT_ENV_ID = "excavsim/TrenchJoint-v0"


def register() -> bool:
    """Register both environments with Gymnasium (done on import); False when Gymnasium is not installed."""
    try:
        import gymnasium
    except ImportError:
        return False
    registry = gymnasium.envs.registration.registry
    if DIG_ENV_ID not in registry:
        gymnasium.register(DIG_ENV_ID, entry_point="excavsim.envs.dig_env:TrenchDigEnv")
    if JOINT_ENV_ID not in registry:
        gymnasium.register(JOINT_ENV_ID, entry_point="excavsim.envs.joint_env:TrenchJointEnv")
    return True


register()
