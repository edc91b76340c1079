"""Reinforcement-learning environments on the trenching testbed, at two levels.

* ``excavsim/TrenchDig-v0`` (:class:`~excavsim.envs.dig_env.TrenchDigEnv`): one step per dig, the
  action Singh's trenching action (k, alpha, d1); the episode is the loop of ``excavsim trench``
  with the agent in the planner's place.
* ``excavsim/LoadDig-v0`` (:class:`~excavsim.envs.load_env.LoadDigEnv`): loading from a pile in
  MuJoCo, one step per dig, the action the loading planner's (k, alpha); the episode is the loop of
  ``excavsim trench --spec`` with ``task: pile_loading`` and the agent in the loading planner's place.
* The joint level, one environment for any trenching machine (:class:`~excavsim.envs.joint_env.JointEnv`
  over :class:`~excavsim.envs.joint_core.JointCore`): one step per control period, the action the set-point
  rates of the machine's four digging joints; the machine is the spec's (or ``machine=``). Three ids,
  each a goal with its defaults (:data:`JOINT_ENV_KWARGS`):

  * ``excavsim/TrenchJoint-v0`` and ``excavsim/TrenchJointDig-v0``: the spec's trench (the T3's by
    default); the first the whole trench (3,000 steps on the T3), the second one dig (600 steps, the
    single-dig task the PPO baseline learns). Both start with the bucket just above the soil.
  * ``excavsim/ExcavatorJoint-v0``: a region of the pit emptied by a hydraulic excavator (DiMaio 1998's
    TB035 by default, or ``machine="excavator_25t"``) at 50 Hz, the action its four valves.

Importing this module registers them with Gymnasium (``gymnasium.make("excavsim/TrenchDig-v0",
spec=...)``; install ``excavsim[envs]``). :mod:`excavsim.envs.dm` has the same environments with a
dm_env face (:class:`~excavsim.envs.dm.DmTrenchDig`, :class:`~excavsim.envs.dm.DmJoint`,
:class:`~excavsim.envs.dm.DmLoadDig`), which needs only dm-env. The cores (:mod:`excavsim.envs.core`,
:mod:`excavsim.envs.joint_core`, :mod:`excavsim.envs.load_core`) know neither library.
"""

from __future__ import annotations

from excavsim.envs.core import DIG_WEIGHTS, OUTCOMES, DigCore, EnvError
from excavsim.envs.joint_core import JOINT_GOALS, JointCore
from excavsim.envs.joint_region import EXCAVATOR_WEIGHTS
from excavsim.envs.joint_trench import DIG_TASK, JOINT_WEIGHTS, TRENCH_TASK

__all__ = ["DIG_WEIGHTS", "DIG_ENV_ID", "ENV_IDS", "EXCAVATOR_JOINT_ENV_ID", "EXCAVATOR_WEIGHTS", "JOINT_DIG_ENV_ID",
           "JOINT_ENV_ID", "JOINT_ENV_KWARGS", "JOINT_GOALS", "JOINT_WEIGHTS", "LOAD_DIG_ENV_ID", "OUTCOMES", "DigCore",
           "EnvError", "JointCore", "register"]

DIG_ENV_ID = "excavsim/TrenchDig-v0"
JOINT_ENV_ID = "excavsim/TrenchJoint-v0"
JOINT_DIG_ENV_ID = "excavsim/TrenchJointDig-v0"
LOAD_DIG_ENV_ID = "excavsim/LoadDig-v0"
EXCAVATOR_JOINT_ENV_ID = "excavsim/ExcavatorJoint-v0"
ENV_IDS = (DIG_ENV_ID, JOINT_ENV_ID, JOINT_DIG_ENV_ID, LOAD_DIG_ENV_ID, EXCAVATOR_JOINT_ENV_ID)
"""Every environment this package registers."""
JOINT_ENV_KWARGS = {JOINT_ENV_ID: {"goal": "trench", **TRENCH_TASK}, JOINT_DIG_ENV_ID: {"goal": "trench", **DIG_TASK},
                    EXCAVATOR_JOINT_ENV_ID: {"goal": "region"}}
"""The joint-level ids: each a registration of :class:`~excavsim.envs.joint_env.JointEnv` with these keywords
(a goal of :data:`~excavsim.envs.joint_core.JOINT_GOALS` and its defaults); ``gymnasium.make(id, machine=...)``
picks the machine (the region's default is the TB035, the trench's the spec's machine, the T3 by default)."""


def register() -> bool:
    """Register the environments of :data:`ENV_IDS` with Gymnasium (done on import); False when
    Gymnasium is not installed. The joint-level ones also register the batched vector environment
    (:class:`~excavsim.envs.batched.BatchedJointEnv`) as their ``vector_entry_point``, which
    ``gymnasium.make_vec`` uses by default (and with ``vectorization_mode="vector_entry_point"``)."""
    try:
        import gymnasium
    except ImportError:
        return False
    registry = gymnasium.envs.registration.registry
    if DIG_ENV_ID not in registry:
        gymnasium.register(DIG_ENV_ID, entry_point="excavsim.envs.dig_env:TrenchDigEnv")
    if LOAD_DIG_ENV_ID not in registry:
        gymnasium.register(LOAD_DIG_ENV_ID, entry_point="excavsim.envs.load_env:LoadDigEnv")
    for env_id, kwargs in JOINT_ENV_KWARGS.items():
        if env_id not in registry:
            gymnasium.register(env_id, entry_point="excavsim.envs.joint_env:JointEnv", kwargs=dict(kwargs),
                               vector_entry_point="excavsim.envs.batched:BatchedJointEnv")
    return True


register()
