"""Campaigns: many episodes over a grid of parameters, run in parallel and resumable (``excavsim campaign``).

:mod:`~excavsim.studies.campaign.grid` reads and expands the campaign file, :mod:`~excavsim.studies.campaign.runner`
runs it, :mod:`~excavsim.studies.campaign.report` writes its tables and plots.
"""
