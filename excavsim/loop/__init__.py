"""Wiring: the demo now; later the dig-scan-plan episode, campaigns and the regression suite."""
