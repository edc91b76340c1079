"""Compile every numba kernel once, so that the first real run starts warm (``excavsim warmup``).

numba compiles a kernel on its first call and, with ``cache=True``, keeps the machine code in a
cache (``__pycache__`` beside the sources of an editable install; numba's user-wide cache directory
when the package's own directory is not writable; ``NUMBA_CACHE_DIR`` when set). On a fresh clone
the first episode pays about 22 s of CPU for compiling (``excavsim bench coldstart`` measures it).
:func:`warm_up` pays it at install time instead (``make`` runs ``excavsim warmup`` after
installing): each task's plug-in runs what its episodes compile
(:meth:`~excavsim.loop.plugin.TaskPlugin.warm_up`).
"""

from __future__ import annotations

import time
from collections.abc import Callable

from excavsim.loop import catalog


def warm_up(say: Callable[[str], None] = print) -> float:
    """Compile (or load from the cache) every kernel the registered tasks use; returns the CPU seconds it took."""
    c0 = time.process_time()
    for plugin in catalog.plugins().values():
        plugin.warm_up(say)
    seconds = time.process_time() - c0
    say(f"warm: {seconds:.1f} s CPU")
    return seconds
