"""Trenching, the robot's mind where it is trenching's alone: :mod:`~excavsim.tasks.trench.mind.fallback`,
the pre-planned boundary-following digs when the planner finds no dig of minimum utility (Singh 1995 §7.2).

The trenching planner itself (:mod:`excavsim.planning`) is shared: the digging rig (which the applications
use too) and the studies plan with it. numpy only: an import-linter contract keeps every task's ``mind``
package off the world, MuJoCo, dm_control and Rerun.
"""
