"""Soil calibration from F/T records (``excavsim calibrate``, DiMaio 1998 §5.5.1).

:mod:`~excavsim.apps.calibrate.fit` fits a soil and reproduces Table 5.3; :mod:`~excavsim.apps.calibrate.digs`
records the digs a calibration fits, reads them back and digs them again.
"""
