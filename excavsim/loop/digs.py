"""Where each cycle's dig comes from: a :class:`DigSource` answers with a :class:`Choice`.

The platform's :class:`~excavsim.loop.episode.Episode` asks its task, and the task its dig source,
for one dig per cycle on the map it just scanned, and tells the source afterwards how the dig went.
Each task has its own sources, named by its plug-in
(:attr:`~excavsim.loop.plugin.TaskPlugin.dig_sources`: a planner, random feasible digs, scripted digs, a
self-tuning script ...); the dig-level environments give the agent's.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from excavsim.handoff.dig import Dig, ExecutionRecord
from excavsim.handoff.maps import ElevationMap
from excavsim.planning.search import PlanResult


@dataclasses.dataclass(frozen=True)
class Choice:
    """A dig source's answer for one cycle.

    Attributes:
        dig: the dig to execute, or None: the episode ends with ``no_dig``.
        reason: why there is no dig (when ``dig`` is None).
        plan: the planner's result, for observers (None when the source did not plan).
        note: a line of progress to print before the dig (e.g. that the planner fell back).
    """

    dig: Dig | None
    reason: str = ""
    plan: PlanResult | None = None
    note: str = ""


class DigSource:
    """Chooses the dig of each cycle on the scanned map, and hears how it went (subclasses choose)."""

    def belief(self, rig: Any, emap: ElevationMap) -> ElevationMap:
        """The map as this source believes it (the scanned one, unless experience corrected it)."""
        return emap

    def choose(self, rig: Any, emap: ElevationMap) -> Choice:
        """The dig for this cycle on ``emap`` (the believed map; see :class:`Choice`)."""
        raise NotImplementedError

    def learned(self, rig: Any, index: int, dig: Dig, record: ExecutionRecord, emap: ElevationMap) -> str | None:
        """After dig ``index`` (chosen on ``emap``) ran: what was learned, as a line of text, or None."""
        return None

