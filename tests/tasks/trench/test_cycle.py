"""One cycle of the loop end to end (an episode of one dig): scan, map, plan on the map, dig, settle, scan."""

from __future__ import annotations

from excavsim.cli import main
from excavsim.handoff.episode import EpisodeObserver, format_episode
from excavsim.loop.scenario import EpisodeSpec, run_spec


class Seen(EpisodeObserver):
    """What the loop showed its observer."""

    def __init__(self):
        self.accuracy, self.plans, self.records = [], [], []

    def started(self, sim, rig, goal_mask, goal_z):
        self.sim = sim

    def scanned(self, index, emap, accuracy):
        self.accuracy.append(accuracy)

    def planned(self, index, plan, dig):
        self.plans.append((plan, dig))

    def dug(self, index, record, metrics):
        self.records.append(record)


def test_one_cycle_digs_from_the_scanned_map_and_conserves_the_soil():
    seen = Seen()
    res = run_spec(EpisodeSpec(name="cycle", dig_budget=1, seed=0), observer=seen)
    before = seen.accuracy[0]
    assert before.rms_m < 0.025 and before.observed_fraction > 0.85
    assert len(seen.accuracy) == 2  # the map before the dig and the one after it
    plan, dig = seen.plans[0]
    assert plan.action is not None and dig.kind == "planned" and dig.action == plan.action
    rec = seen.records[0]
    assert rec.outcome in ("completed", "completed late", "stalled")
    assert res.removed_m3 > 0.005  # a real dig: litres of soil out of the trench's footprint
    assert abs(res.volume_change_m3) < 1e-12 * seen.sim.soil.initial_volume
    assert seen.sim.truth.volumes.bucket == 0.0 or rec.stall is not None
    assert "removed" in format_episode(res)


def test_cli_cycle_reports(capsys):
    assert main(["cycle", "--seed", "1"]) == 0
    out = capsys.readouterr().out
    assert "map" in out and "1 digs" in out and "simulated" in out
