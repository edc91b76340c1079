"""The Rerun recording of a trenching episode, on any trenching machine: the task's ``episode_recorder``.

The trench's entities are :class:`~excavsim.record.trench.TrenchRecorder`'s (in :mod:`excavsim.record`,
since the applications record the T3 with it too); this is the task's hook the platform asks for
(``excavsim run SPEC --record FILE.rrd``, a campaign with ``record: true``).
"""

from __future__ import annotations

import os


def episode_recorder(path: str | os.PathLike, *, live: str | None = None):
    """The Rerun recorder of a trenching episode to ``path`` (an ``.rrd`` file), also streaming to the
    viewer at ``live`` (a gRPC URL) when given."""
    from excavsim.record.trench import TrenchRecorder

    return TrenchRecorder(path, live=live)
