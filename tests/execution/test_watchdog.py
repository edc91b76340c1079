"""The divergence watchdog: an unstable simulation ends the dig as ``diverged`` within a bounded number of
steps, timeouts count steps or a clock that never goes back, and a wall-clock limit ends a runaway episode.

The models are made to diverge by a gravity of 1e12 m/s^2 (far beyond MuJoCo's 1e10 "huge value" bound
on accelerations), switched on by a step observer once the bucket is loaded by the soil: MuJoCo then
warns ``mjWARN_BADQACC`` and resets the state to the model's default with its time back at 0, which
is what an unstable soil or rock contact does (``heavy_clay`` with 100 rocks of 1e8 N/m, seed 1).
"""

from __future__ import annotations

import dataclasses
import time

import mujoco
import numpy as np
import pytest
from rerun.chunk import RrdReader

from excavsim.config import load_executor_config
from excavsim.execution.dig import DigExecutor
from excavsim.handoff.episode import EpisodeObserver, ObserverGroup, format_episode
from excavsim.errors import Diverged, OutOfTime
from excavsim.loop.scenario import EpisodeSpec, dig_rows, episode_summary, run_spec
from excavsim.record import TrenchRecorder
from excavsim.sensing.ft import ForceSensor
from excavsim.world.simulation import Simulation
from tests.execution.test_execution import flat_map, planned_dig, run_dig

HUGE_GRAVITY = -1e12  # [m/s^2]
TINY = {"goal": "small", "dig_budget": 2,
        "sensing": {"map": {"n_scans": 1}, "scanner": {"n_azimuth": 60, "n_elevation": 60}},
        "planner": {"grid": {"k_min_m": 1.8, "k_max_m": 2.6, "k_step_m": 0.2, "alpha_step_deg": 15.0,
                             "d1_step_m": 0.04}}}


class DivergeInTheSoil(EpisodeObserver):
    """Makes the model diverge (gravity 1e12 m/s^2) after the first step with the soil pushing on the
    bucket by more than 50 N; remembers the step count then."""

    def __init__(self):
        self.at_step: int | None = None

    def stepped(self, sim):
        if self.at_step is None and sim.contact is not None and np.linalg.norm(sim.contact.force) > 50.0:
            sim.model.opt.gravity[2] = HUGE_GRAVITY
            self.at_step = sim.steps


def test_a_huge_acceleration_raises_diverged_and_the_clock_does_not_go_back():
    sim = Simulation(seed=0)
    hold = sim.observe().q
    for _ in range(5):
        sim.track(hold)
    t = sim.time
    sim.model.opt.gravity[2] = HUGE_GRAVITY
    with pytest.raises(Diverged, match="mjWARN_BADQACC.*reset the state"):
        sim.track(hold)
    assert sim.data.time < t  # MuJoCo reset its state and its time ...
    assert sim.time == t and sim.observe().time == t  # ... the simulation's clock stays where it was
    assert np.all(np.isfinite(sim.data.qpos))  # the state is finite again: a finite check alone misses this
    sim.model.opt.gravity[2] = -9.81
    with pytest.raises(Diverged, match="diverged earlier"):  # a diverged world is never stepped again
        sim.track(hold)
    assert sim.steps == 6


def test_a_reset_without_a_warning_is_caught_by_the_clock(monkeypatch):
    sim = Simulation(seed=0)
    real_step = mujoco.mj_step
    sim.step()

    def step_and_reset(model, data, nstep=1):
        real_step(model, data, nstep)
        data.time = 0.0  # as mj_resetData would, but without touching the warning counters

    monkeypatch.setattr(mujoco, "mj_step", step_and_reset)
    with pytest.raises(Diverged, match="time went from 0.010 s to 0.000 s"):
        sim.step()


@pytest.fixture(scope="module")
def flat_plan(arm, reach_table):
    return planned_dig(Simulation(seed=0), arm, reach_table, flat_map())


def test_a_dig_in_a_diverging_world_ends_diverged_on_the_next_step(arm, flat_plan):
    sim = Simulation(seed=0)
    trigger = DivergeInTheSoil()
    sim.step_hooks.append(trigger.stepped)
    rec = run_dig(sim, arm, load_executor_config(), flat_plan)
    assert trigger.at_step is not None, "the bucket never met the soil"
    assert rec.outcome == "diverged" and not rec.completed
    assert sim.steps == trigger.at_step + 1  # detected on the first unstable step; no step after it
    assert any("mjWARN_BADQACC" in w for w in rec.warnings), rec.warnings
    assert "touch-down" in rec.phase_starts and "park" not in rec.phase_starts


def test_a_dig_past_the_wall_clock_limit_ends_as_timeout_without_a_step(arm, flat_plan):
    sim = Simulation(seed=0)
    sim.wall_deadline = time.perf_counter() - 1.0
    rec = run_dig(sim, arm, load_executor_config(), flat_plan)
    assert rec.outcome.startswith("timeout: the episode's wall-clock limit passed"), rec.outcome
    assert sim.steps == 0
    with pytest.raises(OutOfTime):
        sim.step()


class FrozenClock:
    """The servos of a simulation whose clock never advances (as MuJoCo's did, reset again and again)."""

    def __init__(self, sim: Simulation, most: int = 20_000):
        self.sim, self.most, self.tracks = sim, most, 0
        self.control_dt, self.torque_limit = sim.control_dt, sim.torque_limit

    @property
    def time(self) -> float:
        return 0.0

    def observe(self):
        return dataclasses.replace(self.sim.observe(), time=0.0)

    def track(self, target):
        self.tracks += 1
        if self.tracks > self.most:
            raise AssertionError(f"the dig was still running after {self.most} steps with a stopped clock")
        return dataclasses.replace(self.sim.track(target), time=0.0)


def test_the_dig_time_limit_counts_steps_when_the_clock_stops(arm, flat_plan):
    sim = Simulation(seed=0)
    cfg = load_executor_config().model_copy(update={"move_timeout_s": 0.3, "dig_timeout_moves": 1})
    servos = FrozenClock(sim)
    rec = DigExecutor(servos, arm, cfg, ForceSensor(sim.model), sim.index.park).run(flat_plan)
    assert rec.outcome.startswith("timeout in step"), rec.outcome
    assert servos.tracks == round(0.3 / sim.control_dt) + 2  # the script's 0.3 s, counted in control steps


def log_lines(path) -> list[str]:
    """The TextLog lines of a recording, decoded from the file."""
    lines = []
    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.entity_path != "/log":
            continue
        batch = chunk.to_record_batch()
        for name in batch.schema.names:
            if name.endswith(":text"):
                lines += [str(v) for row in batch.column(name).to_pylist() if row for v in row]
    return lines


def test_an_episode_whose_world_diverges_ends_diverged_and_says_so_everywhere(tmp_path):
    trigger = DivergeInTheSoil()
    path = tmp_path / "diverged.rrd"
    res = run_spec(EpisodeSpec(name="diverges", **TINY), observer=ObserverGroup(TrenchRecorder(path), trigger))
    assert trigger.at_step is not None
    assert res.end == "diverged" and "mjWARN_BADQACC" in res.reason and "(dig 1)" in res.reason
    assert len(res.digs) == 1  # the budget was 2: nothing runs after the divergence
    dig = res.digs[0]
    assert dig.outcome == "diverged" and dig.failure == "diverged" and dig.failed
    summary = episode_summary(res)
    assert summary["end"] == "diverged" and summary["diverged_digs"] == 1 and summary["failed_digs"] == 1
    assert dig_rows(res)[0]["outcome"] == "diverged"
    table = format_episode(res)
    assert " diverged " in table and "1 diverged" in table
    lines = log_lines(path)
    assert any(line.startswith("dig 1 (planned): diverged") for line in lines), lines
    assert any(line.startswith("ended: the simulation diverged") for line in lines), lines


def test_an_episode_past_its_wall_clock_limit_ends_as_timeout():
    res = run_spec(EpisodeSpec(name="no-time", executor={"episode_wall_limit_s": 1e-6}, **TINY))
    assert res.end == "timeout" and res.digs == []
    assert res.reason == "the episode's wall-clock limit of 1e-06 s passed after 0 digs"
    assert episode_summary(res)["end"] == "timeout"
