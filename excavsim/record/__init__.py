"""Rerun recordings of episodes (the only package that imports rerun) and their replay."""

from excavsim.record.recorder import RerunRecorder
from excavsim.record.replay import replay

__all__ = ["RerunRecorder", "replay"]
