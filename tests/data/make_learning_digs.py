"""Regenerate tests/data/learning_digs.npz: force samples of 12 simulated digs for tests/learning/test_learning.py.

Run from the repository root: ``python tests/data/make_learning_digs.py``. Random feasible digs in
the straight trench of testbed sand (excavsim.studies.learning.collect), with a quick scanner (two scans of
100 x 100 rays) so that it takes about half a minute.
"""

from __future__ import annotations

import pathlib

from excavsim.studies.learning.collect import collect_dataset

OUT = pathlib.Path(__file__).with_name("learning_digs.npz")
QUICK_SCANS = {"sensing": {"map": {"n_scans": 2}, "scanner": {"n_azimuth": 100, "n_elevation": 100}}}

if __name__ == "__main__":
    data = collect_dataset(digs=12, seed=1, digs_per_bed=4, overrides=QUICK_SCANS, progress=print)
    print(f"{len(data)} samples of {data.n_digs} digs -> {data.save(OUT)}")
