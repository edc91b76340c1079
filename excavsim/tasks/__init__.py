"""Tasks: what the machine is asked to do, one home per task (the loop's platform runs them).

:mod:`~excavsim.tasks.trench` holds trenching (Singh 1995 §7.2), :mod:`~excavsim.tasks.pile_loading` loading
from a pile (the 2-D simulation and the MuJoCo one) and :mod:`~excavsim.tasks.dump_trial` Rowe's truck loading
by the self-tuned mass-excavation script. Each is registered by entry point in the platform's catalog
(:mod:`excavsim.loop.catalog`), which is how the platform, and the applications beside the tasks, reach them. No task imports another (an import-linter contract).
"""
