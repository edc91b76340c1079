"""Soil calibration from F/T records (``excavsim calibrate``, DiMaio 1998 §5.5.1).

:mod:`~excavsim.apps.calibrate.fit` fits a soil model to a record, :mod:`~excavsim.apps.calibrate.run` is
``excavsim calibrate`` (fit, preset, re-run, plot, report), :mod:`~excavsim.apps.calibrate.table53`
reproduces Table 5.3; :mod:`~excavsim.apps.calibrate.digs` records the digs a calibration fits, reads
them back and digs them again.
"""
