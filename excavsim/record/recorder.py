"""The trenching recorder under its older module and name: :mod:`excavsim.record.live` (and older scripts)
import ``RerunRecorder`` from here. It is :class:`~excavsim.record.trench.TrenchRecorder`; the recorder base
is :mod:`excavsim.record.base`.
"""

from excavsim.record.base import recording_id_for
from excavsim.record.trench import RerunRecorder, TrenchRecorder

__all__ = ["RerunRecorder", "TrenchRecorder", "recording_id_for"]
