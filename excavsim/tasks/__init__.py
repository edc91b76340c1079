"""Tasks: what the machine is asked to do, one home per task (the loop's platform runs them).

Trenching is still the loop's own episode (:mod:`excavsim.loop`); :mod:`~excavsim.tasks.load` holds loading
from a pile (the 2-D simulation and the MuJoCo one) and :mod:`~excavsim.tasks.truck` Rowe's truck loading
by the self-tuned mass-excavation script. No task imports another (an import-linter contract).
"""
