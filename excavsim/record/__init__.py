"""Rerun recordings of episodes and their replay: the only package that imports rerun.

:class:`EpisodeRecorder` is the recorder base, an :class:`~excavsim.handoff.episode.EpisodeObserver`
that owns a recording's lifecycle (the stream, the timelines, the world's static setup, the samples,
the end); a task's recorder subclasses it and adds its entities with the base's drawing vocabulary
(each task module's ``episode_recorder(path)`` makes one). :class:`TrenchRecorder` records trenching
:func:`replay` opens a recording.
"""

from excavsim.record.base import EpisodeRecorder
from excavsim.record.replay import replay
from excavsim.record.trench import TrenchRecorder

__all__ = ["EpisodeRecorder", "TrenchRecorder", "replay"]
