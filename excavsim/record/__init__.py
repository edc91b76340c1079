"""Rerun recordings of episodes and their replay: the only package that imports rerun.

:class:`RerunRecorder` is an :class:`~excavsim.handoff.episode.EpisodeObserver` that the caller
(the CLI, a campaign, a script) hands to the episode driver; :func:`replay` opens a recording.
"""

from excavsim.record.recorder import RerunRecorder
from excavsim.record.replay import replay

__all__ = ["RerunRecorder", "replay"]
