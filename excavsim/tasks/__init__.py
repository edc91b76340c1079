"""Tasks: what the machine is asked to do, one home per task (the loop's platform runs them).

:mod:`~excavsim.tasks.trench` holds trenching (Singh 1995 §7.2), :mod:`~excavsim.tasks.pile_loading` loading
from a pile (the 2-D simulation and the MuJoCo one), :mod:`~excavsim.tasks.dump_trial` Rowe's trial of the
self-tuned mass-excavation script on the T3 and :mod:`~excavsim.tasks.truck_loading` the 25 t excavator
loading a truck to full. Each is registered by entry point in the platform's catalog
(:mod:`excavsim.loop.catalog`), which is how the platform, and the applications beside the tasks, reach them. No task imports another (an import-linter contract).

Inside a task's folder, what is the task's alone is split by side: ``<task>/mind`` (what the robot
plans and runs from what it senses: numpy only, never the world, MuJoCo, dm_control or Rerun) and
``<task>/world`` (the truth: never the robot's mind, shared or the task's). The contracts are written
over ``excavsim.tasks.*.mind`` and ``excavsim.tasks.*.world``, so they hold in every task, a new one too.
The rest of a folder (the task's hooks, configuration, recording, commands) wires the two sides.
"""
