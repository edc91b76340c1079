"""Reinforcement-learning environments on the excavsim platform: each task's, and the joint level's.

An environment is something a task contributes: its plug-in's ``environments``
(:class:`~excavsim.loop.plugin.EnvEntry`: an id, its entry point, its keywords and its batched vector
implementation), whose classes live in the task's folder. :func:`register` registers every registered
task's environments with Gymnasium (asking the catalog, :func:`excavsim.loop.catalog.plugins`) and the
platform's own (:data:`PLATFORM_ENVIRONMENTS`); importing this module does it. Each id's entry point is in
:func:`environments` (``gymnasium.make("excavsim/TrenchDig-v0", spec=...)``; install ``excavsim[envs]``).

This package is the machinery they share, and names no task and no machine:

* the dig level (one step per dig, the action a task planner's): :class:`~excavsim.envs.core.DigLevelCore`
  (the core's stepping), :class:`~excavsim.envs.dig_env.DigStepEnv` (the Gymnasium face),
  :class:`~excavsim.envs.dig_env.PlannerPolicy` (a task's planner as a policy); each task subclasses them;
* the joint level, one environment for any machine (:class:`~excavsim.envs.joint_env.JointEnv` over
  :class:`~excavsim.envs.joint_core.JointCore`): one step per control period, the action the set-point rates
  of the machine's four digging joints, a goal (a class named by its entry point in the id's keywords, a
  task's or the platform's region goal, :class:`~excavsim.envs.joint_region.JointRegion`) saying what the
  episode is for; its batched vector environment :class:`~excavsim.envs.batched.BatchedJointEnv`;
* the faces' parts: observation fields (:class:`~excavsim.envs.core.Field`), Gymnasium spaces
  (:mod:`~excavsim.envs.spaces`), offscreen frames (:mod:`~excavsim.envs.render`) and the dm_env face
  (:mod:`~excavsim.envs.dm`, which needs only dm-env).

The platform's own id is ``excavsim/ExcavatorJoint-v0``: a region of the pit emptied by a hydraulic
excavator (DiMaio 1998's TB035 by default, or ``machine=`` another of the registry's) at 50 Hz, the action its
four valves. The cores know neither RL library.
"""

from __future__ import annotations

from excavsim.envs.core import EnvError, Field
from excavsim.envs.joint_core import JOINT_ENTRY_POINT, JointCore, joint_goals
from excavsim.envs.joint_region import EXCAVATOR_WEIGHTS
from excavsim.errors import ConfigError
from excavsim.loop import catalog
from excavsim.loop.plugin import EnvEntry

__all__ = ["ENV_IDS", "EXCAVATOR_JOINT_ENV_ID", "EXCAVATOR_WEIGHTS", "PLATFORM_ENVIRONMENTS", "EnvError", "Field",
           "JointCore", "environments", "joint_goals", "register"]

BATCHED_ENTRY_POINT = "excavsim.envs.batched:BatchedJointEnv"
"""The joint-level ids' ``vector_entry_point``: the batched vector environment."""
EXCAVATOR_JOINT_ENV_ID = "excavsim/ExcavatorJoint-v0"
PLATFORM_ENVIRONMENTS = (
    EnvEntry(EXCAVATOR_JOINT_ENV_ID, JOINT_ENTRY_POINT, {"goal": "excavsim.envs.joint_region:JointRegion"},
             BATCHED_ENTRY_POINT),
)
"""The environments of no task: the joint level with the platform's region goal (its machine and soil by
default the goal's, :attr:`JointRegion.SPEC_DEFAULTS <excavsim.envs.joint_region.JointRegion.SPEC_DEFAULTS>`)."""


def environments() -> dict[str, EnvEntry]:
    """Every environment, by id: each registered task's (its plug-in's ``environments``, in the catalog's
    order), then :data:`PLATFORM_ENVIRONMENTS`.

    Raises:
        ConfigError: two tasks (or a task and the platform) contribute the same id.
    """
    found: dict[str, EnvEntry] = {}
    owner: dict[str, str] = {}
    sources = [(name, plugin.environments) for name, plugin in catalog.plugins().items()]
    for source, entries in [*sources, ("the platform", PLATFORM_ENVIRONMENTS)]:
        for entry in entries:
            if entry.id in found:
                raise ConfigError(f"environment {entry.id!r} is contributed by {owner[entry.id]} and by {source}; "
                                  "allowed: one owner per id")
            found[entry.id], owner[entry.id] = entry, source
    return found


def register() -> bool:
    """Register every environment of :func:`environments` with Gymnasium (done on import; call it again after
    registering a task at run time); False when Gymnasium is not installed. The joint-level ones also register
    the batched vector environment (:class:`~excavsim.envs.batched.BatchedJointEnv`) as their
    ``vector_entry_point``, which ``gymnasium.make_vec`` uses by default (and with
    ``vectorization_mode="vector_entry_point"``)."""
    try:
        import gymnasium
    except ImportError:
        return False
    registry = gymnasium.envs.registration.registry
    for env_id, entry in environments().items():
        if env_id not in registry:
            gymnasium.register(env_id, entry_point=entry.entry_point, kwargs=dict(entry.kwargs),
                               vector_entry_point=entry.vector_entry_point)
    return True


ENV_IDS = tuple(environments())
"""Every environment's id when this module was imported (:func:`environments` has those of tasks registered later)."""

register()
