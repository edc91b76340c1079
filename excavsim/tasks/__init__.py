"""Tasks: what the machine is asked to do, one home per task (the loop's platform runs them).

:mod:`~excavsim.tasks.trench` holds trenching (Singh 1995 §7.2), :mod:`~excavsim.tasks.load` loading
from a pile (the 2-D simulation and the MuJoCo one) and :mod:`~excavsim.tasks.truck` Rowe's truck loading
by the self-tuned mass-excavation script. Each is registered by entry point in the platform's catalog
(:mod:`excavsim.loop.catalog`), which is how the platform, and the applications beside the tasks, reach them. No task imports another (an import-linter contract).
"""
