"""The platform's episode: stepped phase by phase it is the episode run to its end; phases out of
order are refused; an error in a phase ends it (here with the trenching task of a specification)."""

from __future__ import annotations

import pytest


def _tiny_episode(**kw):
    from excavsim.loop.scenario import EpisodeSpec, resolve, spec_episode

    fields = {"goal": "small", "dig_budget": 2,
              "sensing": {"map": {"n_scans": 1}, "scanner": {"n_azimuth": 60, "n_elevation": 60}},
              "planner": {"grid": {"k_min_m": 1.8, "k_max_m": 2.6, "k_step_m": 0.2, "alpha_step_deg": 15.0}}}
    spec = EpisodeSpec(**{**fields, **kw})
    return spec, spec_episode(spec, resolve(spec))


def test_an_episode_stepped_phase_by_phase_is_run_episode_and_refuses_phases_out_of_order():
    from excavsim.handoff.episode import EpisodeObserver
    from excavsim.loop.episode import EpisodeError
    from excavsim.loop.scenario import episode_summary, run_spec, spec_digs

    class Hooks(EpisodeObserver):
        def __init__(self):
            self.calls = []

        def started(self, sim, rig, goal_mask, goal_z):
            self.calls.append("started")

        def scanned(self, index, emap, accuracy):
            self.calls.append(f"scanned {index}")

        def planned(self, index, plan, dig):
            self.calls.append(f"planned {index}")

        def dug(self, index, record, metrics):
            self.calls.append(f"dug {index}")

        def finished(self, result):
            self.calls.append("finished" if result is not None else "finished None")

    spec, _ = _tiny_episode(dig_budget=2, done_fraction=1.0, tolerance_m=0.001)
    whole = episode_summary(run_spec(spec))
    hooks = Hooks()
    _, ep = _tiny_episode(dig_budget=2, done_fraction=1.0, tolerance_m=0.001)
    ep.observer = hooks
    with pytest.raises(EpisodeError, match="call reset"):
        ep.look()
    ep.reset(spec.seed, digs=spec_digs(spec))
    with pytest.raises(EpisodeError, match="the next phase is look"):
        ep.dig()
    emap = ep.look()
    assert emap is not None and ep.index == 1 and not ep.over
    ep.decide()
    ep.dig()
    assert len(ep.task.metrics) == 1 and ep.task.record is not None
    ep.step()  # a whole cycle: the second dig
    assert not ep.over and len(ep.task.metrics) == 2
    ep.step()  # the last scan: the budget is spent
    assert ep.over and ep.result.end == "budget"
    timing = ("wall_s", "planning_s")
    assert {k: v for k, v in episode_summary(ep.result).items() if k not in timing} == \
        {k: v for k, v in whole.items() if k not in timing}
    assert hooks.calls == ["started", "scanned 1", "planned 1", "dug 1", "scanned 2", "planned 2", "dug 2",
                           "scanned 3", "finished"]
    with pytest.raises(EpisodeError, match="has ended"):
        ep.step()
    ep.reset(spec.seed, digs=spec_digs(spec))  # again, then abandoned: the observers hear finished(None)
    ep.look()
    ep.close()
    assert hooks.calls[-3:] == ["started", "scanned 1", "finished None"] and ep.over
    assert ep.sim.step_hooks == []


def test_an_error_in_a_phase_ends_the_episode_with_finished_none():
    from excavsim.handoff.episode import EpisodeObserver
    from excavsim.loop.digs import DigSource

    class Broken(DigSource):
        def choose(self, rig, emap):
            raise RuntimeError("the source broke")

    class Ends(EpisodeObserver):
        result = "not called"

        def finished(self, result):
            self.result = result

    _, ep = _tiny_episode()
    ep.observer = ends = Ends()
    ep.reset(0, digs=Broken())
    with pytest.raises(RuntimeError, match="the source broke"):
        ep.step()
    assert ep.over and ends.result is None and ep.sim.step_hooks == [] and ep.sim.wall_deadline is None
