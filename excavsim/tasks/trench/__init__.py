"""Trenching (Singh 1995 §7.2, Fig. 107): the T3 digs a trench goal out of its soil box.

:mod:`~excavsim.tasks.trench.task` is the task (:class:`~excavsim.tasks.trench.task.TrenchTask`, its
done test and metrics, :func:`~excavsim.tasks.trench.task.run_episode`); :mod:`~excavsim.tasks.trench.digs`
its dig sources (the planner and its fallback, random feasible digs, scripted digs);
:mod:`~excavsim.tasks.trench.demo` the demo's one scripted dig; :mod:`~excavsim.rig.online`
learning the planner's force model while digging; :mod:`~excavsim.tasks.trench.plan_dig` ``excavsim plan``
(one dig on a map, outside any episode); :mod:`~excavsim.tasks.trench.timing` Table 7's per-cycle times.
The planner (shared with the digging rig and the studies) is :mod:`excavsim.planning`;
what is trenching's alone on the mind side is :mod:`~excavsim.tasks.trench.mind` (the boundary-following
fallback, §7.2), kept off the world by an import-linter contract.
"""
