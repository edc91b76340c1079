"""Truck loading, self-tuned (Rowe 1997 §4.2, §5.4, §6.2): every tuned parameter acts, the
learner trades time once the placement is right, the recording holds its entities, the campaign's table."""

from __future__ import annotations

import dataclasses
import math
import pathlib
import shutil
import subprocess
import sys
from collections import defaultdict

import numpy as np
import pytest

from excavsim import cli
from excavsim.errors import ExcavsimError
from excavsim.learning.lwr_tuning import Memory, Objective, select_action
from excavsim.tasks.dump_trial import trial as truck
from excavsim.tasks.dump_trial import tuning
from excavsim.tasks.dump_trial.trial import FRACTIONS, TUNED


@pytest.fixture(scope="module")
def cfg():
    return truck.load_truck_config()


@pytest.fixture(scope="module")
def base(cfg):
    return truck.nominal_params(cfg, seed=0)


@pytest.mark.slow
def test_every_tuned_parameter_changes_the_trial(cfg, base):
    """§6.2 tunes "the most relevant" parameters: each of the seven, moved by 8 deg (0.15 for a fraction)
    from the computed value, changes the script's time or where the pile lands. (``open_lead``, tuned
    before, changed nothing: the stick's condition of the same rule held later.)"""
    ref = truck.run_trial(base, cfg, seed=0)
    for i, name in enumerate(TUNED):
        x = base.values(TUNED)
        x[i] -= 0.15 if name in FRACTIONS else math.radians(8.0)
        t = truck.run_trial(base.with_values(TUNED, x), cfg, seed=0)
        moved = math.hypot(t.pile.x - ref.pile.x, t.pile.y - ref.pile.y)
        assert abs(t.time_s - ref.time_s) > 0.02 or moved > 0.01, name


def test_open_lead_alone_does_not_change_the_trial(cfg, base):
    """Why ``open_lead`` is computed and not tuned: at the computed parameters it does not act."""
    ref = truck.run_trial(base, cfg, seed=0)
    t = truck.run_trial(dataclasses.replace(base, open_lead=base.open_lead + math.radians(10.0)), cfg, seed=0)
    assert t.time_s == ref.time_s and (t.pile.x, t.pile.y) == (ref.pile.x, ref.pile.y)


def _time_memory(n=10, seed=0, noise=(0.0, 0.0)):
    """Trials where input 0 sets the time (3 + x0 s) and inputs 1, 2 set the pile (r, theta) linearly, with
    Gaussian measurement noise of ``noise`` (r [m], theta [rad]) on the pile."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(0.0, 1.0, (n, 3))
    m = Memory(3)
    for xi in x:
        m.add(xi, 3.0 + xi[0], 1.6 + 0.2 * xi[1] + rng.normal(0.0, noise[0]),
              0.5 + 0.2 * xi[2] + rng.normal(0.0, noise[1]))
    return x, m


def test_the_learner_trades_time_when_placement_is_right():
    """With the cost of §6.2 (w1 = 5, w2 = 1696 as configured) the simplex goes to lower time than any trial
    and to the placement that hits the target (r 1.7 m, theta 0.6 rad: x1 = x2 = 0.5)."""
    x, m = _time_memory()
    obj = Objective(1.7, 0.6, 5.0, 1696.0, trust_radius=0.25, uncertainty=False)
    sel = select_action(m, obj)
    assert sel.x[0] < x[:, 0].min()
    np.testing.assert_allclose(sel.x[1:], [0.5, 0.5], atol=0.05)


def test_the_expected_cost_holds_the_learner_at_its_data():
    """The measured cause of the flat time: with the expected cost (w2 times the predicted placement
    variance) on few trials with a noisy pile (3 cm, 1 deg), the learner stays near the data, far above the
    time it goes to without it."""
    x, m = _time_memory(n=10, seed=0, noise=(0.03, 0.02))
    free = select_action(m, Objective(1.7, 0.6, 5.0, 1696.0, trust_radius=0.25, uncertainty=False))
    held = select_action(m, Objective(1.7, 0.6, 5.0, 1696.0, trust_radius=0.25, uncertainty=True))
    assert free.x[0] < held.x[0] - 0.1


def test_the_default_configuration_has_the_expected_cost_off_and_two_trials_after_a_move(cfg):
    assert cfg.expected_cost is False and cfg.objective.uncertainty is False
    assert cfg.retarget_trials == 2
    base = truck.nominal_params(cfg, seed=0)
    lo, hi = truck.tuned_bounds(base, cfg)
    k = TUNED.index("stick_fraction")
    assert (lo[k], hi[k]) == cfg.stick_fraction_range
    # §5.4.1 / Fig. 3: the boom at the dump may rise, never drop below its clearance over the truck's side
    k = TUNED.index("boom_dump")
    assert math.isfinite(base.boom_clear_dump) and lo[k] == pytest.approx(max(base.boom_clear_dump,
                                                                             base.boom_dump - cfg.angle_range))
    assert hi[k] == pytest.approx(base.boom_dump + cfg.angle_range)


def test_a_bad_learning_flag_names_the_field(tmp_path):
    text = truck.TRUCK_YAML.read_text().replace("expected_cost: false", "expected_cost: maybe")
    bad = tmp_path / "dump_trial.yaml"
    bad.write_text(text)
    with pytest.raises(ExcavsimError, match="learning.expected_cost: Input should be a valid boolean"):
        truck.load_truck_config(bad)
    bad.write_text(truck.TRUCK_YAML.read_text().replace("stick_fraction: [0.1, 0.9]", "stick_fraction: [0.9, 0.1]"))
    with pytest.raises(ExcavsimError, match="ranges.stick_fraction"):
        truck.load_truck_config(bad)


def test_a_move_is_followed_by_computed_trials_then_learning(cfg):
    trials = tuning.tune(5, dataclasses.replace(cfg, initial_trials=2), seed=0, retarget=(3, 1.6, math.radians(45)))
    assert [t.source for t in trials] == ["computed + noise"] * 2 + ["learned"] + ["computed + noise"] * 2
    assert trials[-1].r_d == 1.6 and trials[0].r_d == cfg.site.r_d


def _entities(path: pathlib.Path) -> dict[str, dict[str, int]]:
    from rerun.chunk import RrdReader

    tree: dict[str, dict] = defaultdict(lambda: defaultdict(int))
    for chunk in RrdReader(path).stream().to_chunks():
        for key in (["static"] if chunk.is_static else list(chunk.timeline_names)):
            tree[chunk.entity_path][key] += chunk.num_rows
    return tree


def test_a_recorded_tuning_run_passes_rerun_verify_and_holds_its_entities(tmp_path, cfg):
    from excavsim.tasks.dump_trial.recording import TruckRecorder

    path = tmp_path / "tune.rrd"
    small = dataclasses.replace(cfg, initial_trials=1)
    trials = tuning.tune(2, small, seed=0, observer=TruckRecorder(path, seed=0), retarget=(1, 1.6, math.radians(45)))
    here = pathlib.Path(sys.executable).parent / "rerun"
    exe = str(here) if here.exists() else shutil.which("rerun")
    assert exe is not None, "the rerun CLI (installed with rerun-sdk) is missing"
    done = subprocess.run([exe, "rrd", "verify", str(path)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    tree = _entities(path)
    for per_trial in ("/world/pile/measured", "/world/pile/true", "/world/soil/scan", "/world/exec/path",
                      "/metrics/cost", "/metrics/time_s", "/metrics/sq_error_m2"):
        assert tree[per_trial]["trial"] == 2, per_trial
    assert tree["/world/target"]["trial"] == 2 and tree["/world/truck"]["trial"] == 2  # logged again on the move
    for sub in ("swing", "boom", "stick", "bucket"):  # the phases: every step change plus each script's end
        assert tree[f"/script/{sub}"]["sim_time"] >= 2 * 4, sub
    n_ticks = sum(len(t.trace.times) for t in trials)
    assert tree["/joint_deg/swing"]["sim_time"] == n_ticks
    assert tree["/config"]["static"] == 1 and tree["/summary"]["trial"] == 1
    with pytest.raises(ExcavsimError, match=".rrd"):
        TruckRecorder(tmp_path / "x.txt")


@pytest.mark.slow
def test_the_campaign_table_on_a_tiny_case(tmp_path, cfg):
    from excavsim.tasks.dump_trial.campaign import format_tuning_table, run_tuning_campaign

    small = dataclasses.replace(cfg, initial_trials=1)
    runs = run_tuning_campaign(seeds=[0], soils=["testbed_sand", "sandy_loam"], trials=2,
                        retarget=(1, 1.6, math.radians(45)), cfg=small, out=tmp_path)
    assert [(r.soil, r.kind) for r in runs] == [(s, k) for s in ("testbed_sand", "sandy_loam")
                                                for k in ("tuned", "untuned", "moved")]
    assert all(r.after_move is not None for r in runs if r.kind == "moved")
    table = format_tuning_table(runs, 1)
    assert table.count("| testbed_sand | 0 |") == 1 and table.count("| sandy_loam | 0 |") == 1
    assert "tuned beats untuned (last 1) in " in table and "re-learnt in " in table
    rows = (tmp_path / "truck_campaign.csv").read_text().splitlines()
    assert len(rows) == 1 + 2 * 3 * 2 and rows[0].startswith("soil,seed,run,trial")
    assert (tmp_path / "truck_campaign.txt").read_text().strip() == table
    # the same soil and seed give the same first trial in every run (the untuned baseline is paired)
    assert len({(r.first.cost, r.first.time_s) for r in runs if r.soil == "testbed_sand"}) == 1
    with pytest.raises(ExcavsimError, match="allowed"):
        run_tuning_campaign(seeds=[0], soils=["no_such_soil"], trials=2, cfg=small)
    with pytest.raises(ExcavsimError, match="at least 2 trials"):
        run_tuning_campaign(seeds=[0], soils=["testbed_sand"], trials=1, cfg=small)


@pytest.mark.parametrize("argv, message", [
    (["tune", "--trials", "4", "--retarget", "9"], "allowed: 1 to --trials"),
    (["tune", "--trials", "2", "--soil", "no_such_soil"], "allowed"),
    (["tune", "--compare", "--record", "x.rrd"], "--record writes one run"),
])
def test_tune_refuses_bad_arguments(argv, message, capsys, tmp_path):
    assert cli.main([*argv, "--out", str(tmp_path)]) == 2
    assert message in capsys.readouterr().err


def test_tune_record_must_be_an_rrd_file(capsys, tmp_path):
    assert cli.main(["tune", "--record", str(tmp_path / "x.txt")]) == 2
    assert ".rrd" in capsys.readouterr().err
