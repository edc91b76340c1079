"""The trench's environments: what trenching contributes to :mod:`excavsim.envs` (its plug-in's ``environments``).

* ``excavsim/TrenchDig-v0`` (:class:`~excavsim.tasks.trench.envs.dig_env.TrenchDigEnv` over
  :class:`~excavsim.tasks.trench.envs.core.DigCore`): one step per dig, the action Singh's trenching action
  (k, alpha, d1); the episode is the loop of ``excavsim trench`` with the agent in the planner's place.
* ``excavsim/TrenchJoint-v0`` and ``excavsim/TrenchJointDig-v0``: the platform's joint-level environment
  (:class:`~excavsim.envs.joint_env.JointEnv`, any trenching machine) with the trench goal
  (:class:`~excavsim.tasks.trench.envs.joint.JointTrench`, named by its entry point :data:`JOINT_GOAL` in the
  ids' keywords) and the defaults :data:`TRENCH_TASK` and :data:`DIG_TASK`; their batched vector environment
  takes the goal's compiled path on the T3 (:class:`~excavsim.tasks.trench.envs.batched.TrenchBatch`).

The dm_env faces are :mod:`~excavsim.tasks.trench.envs.dm`. The ids and the defaults are declared in the
task's plug-in (:mod:`excavsim.tasks.trench.plugin`) and named here too.
"""

from __future__ import annotations

from excavsim.tasks.trench.plugin import (DIG_ENV_ID, DIG_TASK, ENV_IDS, JOINT_DIG_ENV_ID, JOINT_ENV_ID, JOINT_GOAL,
                                          TRENCH_TASK)

__all__ = ["DIG_ENV_ID", "DIG_TASK", "ENV_IDS", "JOINT_DIG_ENV_ID", "JOINT_ENV_ID", "JOINT_GOAL", "TRENCH_TASK"]
