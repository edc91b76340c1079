"""Trenching's warm-up: compile every numba kernel a trench episode uses once, so that the first real run starts warm.

numba compiles a kernel on its first call and, with ``cache=True``, keeps the machine code in a
cache (``__pycache__`` beside the sources of an editable install; numba's user-wide cache directory
when the package's own directory is not writable; ``NUMBA_CACHE_DIR`` when set). On a fresh clone
the first episode pays about 22 s of CPU for compiling (``excavsim bench coldstart`` measures it).
:func:`warm_up` pays it at install time instead (``make`` runs ``excavsim warmup`` after
installing): it runs one short episode through every path of the loop (scanning, planning with the
compiled kernel, the executor, the soil, settlement) and the reference paths a default episode may
take (the planner's vectorized statics, used by the fallback and learned predictors).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from excavsim.handoff.maps import ElevationMap
from excavsim.rig.core import make_rig
from excavsim.loop.scenario import EpisodeSpec, run_spec
from excavsim.world.simulation import Simulation

# one dig of the small trench on coarse scans: every kernel of an episode, the fewest steps
WARMUP_SPEC = {
    "name": "warmup", "task": "trench", "goal": "small", "dig_budget": 1, "seed": 0,
    "sensing": {"map": {"n_scans": 1}, "scanner": {"n_azimuth": 60, "n_elevation": 60}},
    "planner": {"grid": {"k_min_m": 1.8, "k_max_m": 2.6, "k_step_m": 0.2, "alpha_step_deg": 15.0,
                         "d1_step_m": 0.04}},
}


def warm_up(say: Callable[[str], None] = print) -> None:
    """Compile (or load from the cache) every kernel a trench episode uses."""
    say("warming the numba cache: one short episode ...")
    run_spec(EpisodeSpec(**WARMUP_SPEC))
    say("warming the numba cache: the planner's reference path ...")
    rig = make_rig(Simulation(seed=0))
    flat = ElevationMap(0.55, -1.5, 0.05, np.full((60, 60), 0.5), np.ones((60, 60), bool), 0.0)
    rig.planner.plan(flat, kernel=False)
