"""Reinforcement-learning environments on the trenching testbed, at two levels.

* ``excavsim/TrenchDig-v0`` (:class:`~excavsim.envs.dig_env.TrenchDigEnv`): one step per dig, the
  action Singh's trenching action (k, alpha, d1); the episode is the loop of ``excavsim trench``
  with the agent in the planner's place.
* ``excavsim/TrenchJoint-v0`` and ``excavsim/TrenchJointDig-v0``
  (:class:`~excavsim.envs.joint_env.TrenchJointEnv`): one step per control period, the action the
  servos' set-point rates; the first the whole trench (3,000 steps), the second one dig (600 steps,
  the single-dig task the PPO baseline learns). Both start with the bucket just above the soil.
* ``excavsim/LoadDig-v0`` (:class:`~excavsim.envs.load_env.LoadDigEnv`): loading from a pile in
  MuJoCo, one step per dig, the action the loading planner's (k, alpha); the episode is the loop of
  ``excavsim trench --spec`` with ``task: load`` and the agent in the loading planner's place.
* ``excavsim/ExcavatorJoint-v0`` (:class:`~excavsim.envs.excavator_env.ExcavatorJointEnv`): a hydraulic
  excavator (DiMaio 1998's TB035 by default) at 50 Hz, the action its four valves (swing, boom, stick and
  bucket set-point rates), rewarded for soil removed from a goal region of its pit.

Importing this module registers them with Gymnasium (``gymnasium.make("excavsim/TrenchDig-v0",
spec=...)``; install ``excavsim[envs]``). :mod:`excavsim.envs.dm` has the same environments with a
dm_env face (:class:`~excavsim.envs.dm.DmTrenchDig`, :class:`~excavsim.envs.dm.DmTrenchJoint`,
:class:`~excavsim.envs.dm.DmLoadDig`), which
needs only dm-env. The cores (:mod:`excavsim.envs.core`, :mod:`excavsim.envs.joint_core`,
:mod:`excavsim.envs.load_core`) know neither library.
"""

from __future__ import annotations

from excavsim.envs.core import DIG_WEIGHTS, OUTCOMES, DigCore, EnvError
from excavsim.envs.joint_core import DIG_TASK, JOINT_WEIGHTS, TRENCH_TASK, JointCore

__all__ = ["DIG_WEIGHTS", "DIG_ENV_ID", "ENV_IDS", "EXCAVATOR_JOINT_ENV_ID", "JOINT_DIG_ENV_ID", "JOINT_ENV_ID", "JOINT_WEIGHTS",
           "LOAD_DIG_ENV_ID", "OUTCOMES", "DigCore", "EnvError", "JointCore", "register"]

DIG_ENV_ID = "excavsim/TrenchDig-v0"
JOINT_ENV_ID = "excavsim/TrenchJoint-v0"
JOINT_DIG_ENV_ID = "excavsim/TrenchJointDig-v0"
LOAD_DIG_ENV_ID = "excavsim/LoadDig-v0"
EXCAVATOR_JOINT_ENV_ID = "excavsim/ExcavatorJoint-v0"
ENV_IDS = (DIG_ENV_ID, JOINT_ENV_ID, JOINT_DIG_ENV_ID, LOAD_DIG_ENV_ID, EXCAVATOR_JOINT_ENV_ID)
"""Every environment this package registers."""


def register() -> bool:
    """Register the environments of :data:`ENV_IDS` with Gymnasium (done on import); False when
    Gymnasium is not installed. The joint-level ones also register the batched vector environment
    (:class:`~excavsim.envs.batched.BatchedJointEnv`) as their ``vector_entry_point``, which
    ``gymnasium.make_vec(..., vectorization_mode="vector_entry_point")`` uses."""
    try:
        import gymnasium
    except ImportError:
        return False
    registry = gymnasium.envs.registration.registry
    if DIG_ENV_ID not in registry:
        gymnasium.register(DIG_ENV_ID, entry_point="excavsim.envs.dig_env:TrenchDigEnv")
    if LOAD_DIG_ENV_ID not in registry:
        gymnasium.register(LOAD_DIG_ENV_ID, entry_point="excavsim.envs.load_env:LoadDigEnv")
    if EXCAVATOR_JOINT_ENV_ID not in registry:
        gymnasium.register(EXCAVATOR_JOINT_ENV_ID, entry_point="excavsim.envs.excavator_env:ExcavatorJointEnv")
    for env_id, task in ((JOINT_ENV_ID, TRENCH_TASK), (JOINT_DIG_ENV_ID, DIG_TASK)):
        if env_id not in registry:
            gymnasium.register(env_id, entry_point="excavsim.envs.joint_env:TrenchJointEnv", kwargs=dict(task),
                               vector_entry_point="excavsim.envs.batched:BatchedJointEnv")
    return True


register()
