"""Self-tuning as the truck task's dig source: a spec's tuning run is ``tune``'s, and a campaign compares it."""

from __future__ import annotations

import pytest

from excavsim import constants
from excavsim.errors import ConfigError
from excavsim.loop.scenario import EpisodeSpec, resolve, dig_rows, episode_summary, run_spec
from excavsim.tasks.dump_trial import trial as truck
from excavsim.tasks.dump_trial import tuning

# one computed trial, then the tuner: the learned path within three trials
SMALL = {"learning": {"initial_trials": 1}, "tuning": {"trials": 3}}


def test_a_specs_tuning_run_is_tunes_trial_by_trial_and_records_every_trial(tmp_path):
    from excavsim.record.replay import check_recording
    from excavsim.tasks.dump_trial.episode import episode_recorder
    from tests.tasks.dump_trial.test_truck_tuning import _entities

    spec = EpisodeSpec(task="dump_trial", seed=2, dump_trial=SMALL)
    rrd = tmp_path / "run.rrd"
    run = run_spec(spec, observer=episode_recorder(str(rrd)))
    alone = tuning.tune(3, truck.truck_config(resolve(spec)), seed=2)
    assert [t.source for t in run.tuning_trials] == ["computed + noise"] * 2 + ["learned"]
    for a, b in zip(run.tuning_trials, alone, strict=True):
        assert a.params == b.params and a.time_s == b.time_s and a.pile == b.pile
        assert a.predicted_cost == b.predicted_cost or (a.predicted_cost != a.predicted_cost
                                                        and b.predicted_cost != b.predicted_cost)
    s = episode_summary(run)
    assert s["task"] == "dump_trial" and s["tuning"] == "tuned" and s["trials"] == s["digs"] == 3
    assert s["first_cost"] == pytest.approx(truck.trial_cost(alone[0], truck.truck_config(resolve(spec))))
    assert s["cost"] == s["last_cost"] and s["cycle_s"] == s["last_time_s"] == alone[-1].time_s
    assert s["end"] == ("done" if not alone[-1].failed else "budget")
    assert [r["dig"] for r in dig_rows(run)] == [1, 2, 3]
    check_recording(str(rrd))
    tree = _entities(rrd)
    assert tree["/metrics/cost"]["trial"] == 3 and tree["/summary"]["trial"] == 1


def test_the_untuned_baseline_and_a_given_tuner_choose_computed_parameters_plus_noise():
    from excavsim.loop.catalog import dig_source
    from excavsim.loop.scenario import spec_episode
    from excavsim.tasks.dump_trial.tuning import Tuner

    spec = EpisodeSpec(task="dump_trial", seed=0, dump_trial={**SMALL, "tuning": {"trials": 2, "learn": False}})
    run = run_spec(spec)
    assert not run.learn and [t.source for t in run.tuning_trials] == ["computed + noise"] * 2
    assert episode_summary(run)["tuning"] == "untuned"
    cfg = truck.truck_config(resolve(spec))
    tuner = dig_source("dump_trial", "tuner", cfg, learn=False, seed=0)
    assert isinstance(tuner, Tuner)
    episode = spec_episode(EpisodeSpec(task="dump_trial", seed=0, dump_trial={**SMALL, "tuning": {"trials": 2}}))
    episode.reset(0, digs=tuner)  # the tuned spec, digging with the untuned tuner given: the same run
    again = episode.run()
    assert [t.time_s for t in again.tuning_trials] == [t.time_s for t in run.tuning_trials]


def test_a_tuning_run_is_refused_without_two_windows_and_a_campaign_varies_learning():
    from excavsim.studies.campaign.grid import expand_grid, load_campaign

    with pytest.raises(ConfigError, match="tuning.trials: a tuning run needs at least 12 trials"):
        resolve(EpisodeSpec(task="dump_trial", dump_trial={"tuning": {"trials": 8}}))
    with pytest.raises(ConfigError, match="trials"):
        resolve(EpisodeSpec(task="dump_trial", dump_trial={"tuning": {"trials": 1}}))
    episodes = expand_grid(load_campaign(constants.CONFIGS_DIR / "campaigns" / "truck_tuning.yaml"))
    assert len(episodes) == 8 and len({e.id for e in episodes}) == 8
    assert {(e.spec.soil, e.spec.options.dump_trial["tuning"]["learn"], e.spec.seed) for e in episodes} == \
        {(s, learn, seed) for s in ("testbed_sand", "sandy_loam") for learn in (True, False) for seed in (0, 1)}
    assert all(resolve(e.spec).tuning.trials == 12 for e in episodes)
