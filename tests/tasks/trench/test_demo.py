"""The demo job: one hand-picked dig through the episode driver, a dump to spoil, and the soil settling."""

from __future__ import annotations

import math

import numpy as np
import pytest

from excavsim.cli import main
from excavsim.errors import ExcavsimError
from excavsim.handoff.dig import TrenchAction
from excavsim.handoff.episode import EpisodeObserver
from excavsim.tasks.trench.demo import run_demo
from excavsim.handoff.dig import DEMO_ACTION
from excavsim.world.simulation import Simulation


class Records(EpisodeObserver):
    def started(self, sim, rig, goal_mask, goal_z):
        self.records = []

    def dug(self, index, record, metrics):
        self.records.append(record)


@pytest.fixture(scope="module")
def demo():
    sim, seen = Simulation(seed=0), Records()
    return sim, run_demo(sim, observer=seen), seen.records[0]


def test_demo_digs_the_scripted_action(demo):
    _, res, rec = demo
    (dig,) = res.digs
    assert dig.kind == "scripted" and dig.action == DEMO_ACTION
    assert rec.outcome in ("completed", "completed late")
    assert rec.path_error() < 0.03  # the tip follows the scripted path in flat sand


def test_demo_stays_within_the_relief_limits(demo):
    sim, res, _ = demo
    assert np.all(res.digs[0].peak_torque_nm <= sim.torque_limit + 1e-6)


def test_demo_digs_dumps_and_conserves_the_soil(demo):
    """A whole dig, dump and settle: box + bucket + spoil stays at its initial volume."""
    sim, res, rec = demo
    assert abs(res.volume_change_m3) <= 1e-12 * sim.soil.initial_volume
    assert 0.015 < res.digs[0].bucket_m3  # about a bucketful (struck capacity 0.0204 m^3)
    assert sim.truth.volumes.bucket == pytest.approx(0.0, abs=1e-12)  # all of it left the bucket
    assert res.removed_m3 > 0.01
    start, end = rec.phase_starts["dig"], rec.phase_starts["lift out"]
    digging = [np.linalg.norm(f) for t, f in rec.ft if start <= t <= end]
    assert 100 < np.median(digging) < 3000  # wedge forces of hundreds of N (Fig. 59)


def test_an_unreachable_demo_dig_is_refused_with_a_clear_message():
    with pytest.raises(ExcavsimError, match="out of reach"):
        run_demo(Simulation(seed=0), action=TrenchAction(4.5, math.radians(40.0), 0.2, 0.4))


def test_cli_demo_runs(capsys):
    assert main(["demo", "--seed", "3"]) == 0
    out = capsys.readouterr().out
    assert "scripted" in out and "wrist pred/meas" in out
