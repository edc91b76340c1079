"""Rowe's truck loading with the 25 t excavator: the truck's volume account, a one-pass episode and (slow) a
full truck. The script's geometry and runner are tested in tests/execution/test_rowe_script.py, AutoDig in
tests/tasks/truck_loading/test_autodig.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from excavsim.errors import ConfigError
from excavsim.loop.episode import Episode
from excavsim.loop.scenario import EpisodeSpec, episode_summary, load_spec, resolve, run_spec
from excavsim.tasks.truck_loading.config import load_truck_loading_file
from excavsim.tasks.truck_loading.task import TruckLoadingTask, truck_spec
from excavsim.tasks.truck_loading.world.truck import TruckBed, TruckSpec

SPEC = "configs/specs/excavator_truck.yaml"


def test_the_bed_catches_what_falls_over_it_and_passes_on_the_rest():
    bed = TruckBed(TruckSpec(), math.radians(34.0))
    t = bed.truck
    # a pour 0.3 m inside the near side with a 0.6 m radius: part lands on the bed, part falls beside it
    x, y = t.x_m, t.y_m - 0.5 * t.width_m + 0.3
    rest, caught = bed.catch(np.array([x]), np.array([y]), np.array([0.8]), 0.6)
    assert 0.0 < caught < 0.8 and rest[0] > 0.0
    assert rest[0] + caught == pytest.approx(0.8, abs=1e-12)
    assert bed.volume() == pytest.approx(caught, abs=1e-12)  # settling inside the sides keeps the volume
    # all of it over the middle of the bed
    rest, caught = bed.catch(np.array([t.x_m]), np.array([t.y_m]), np.array([0.5]), 0.6)
    assert caught == pytest.approx(0.5, abs=1e-12) and rest[0] == pytest.approx(0.0, abs=1e-12)
    u, v = bed.centroid_offset()
    assert abs(u) < 0.2 and -0.5 < v < 0.0  # the first pour pulled the centre towards the near side


def test_one_pass_puts_soil_in_the_bed_and_the_account_closes():
    cfg = load_truck_loading_file()
    task = TruckLoadingTask("excavator_25t", cfg=cfg, soil="dry_sand")
    ep = Episode(task, dig_budget=1)
    ep.reset(0)
    total = task.world.volume_account()["total"]
    res = ep.run()
    acc = task.world.volume_account()
    assert res.end == "budget" and len(res.passes) == 1
    p = res.passes[0]
    assert p.bucket_m3 > 0.5 and p.bed_m3 > 0.5  # a 1.19 m^3 heaped bucket, most of it in the truck
    assert acc["bed"] == pytest.approx(p.bed_m3, abs=1e-9)
    assert acc["total"] == pytest.approx(total, abs=1e-9)  # pit + bucket + bed + spoil is constant
    assert p.outcome == "end" and 5.0 < p.script_s < 30.0
    assert p.boom_at_swing >= p.boom_trigger - 1e-9  # the swing started once the boom passed the trigger
    row = episode_summary(res)
    assert row["task"] == "truck_loading" and row["digs"] == 1 and row["truck_l"] > 500.0


def test_the_spec_and_its_refusals():
    spec = load_spec(SPEC)
    assert spec.task == "truck_loading" and spec.machine_name == "excavator_25t"
    assert resolve(spec).truck.payload_t == pytest.approx(12.0)
    with pytest.raises(ConfigError, match="does not do task truck_loading"):
        EpisodeSpec(task="truck_loading", machine="t3")
    with pytest.raises(ConfigError, match="truck_loading"):
        EpisodeSpec(task="trench", truck_loading={"truck": {"payload_t": 10.0}})
    bad = EpisodeSpec.model_validate({**spec.model_dump(), "truck_loading": {"truck": {"payload_t": -1.0}}})
    with pytest.raises(ConfigError, match="payload_t"):
        resolve(bad)
    assert truck_spec(load_truck_loading_file()).payload_kg == pytest.approx(12000.0)


@pytest.mark.slow
def test_a_full_truck():
    res = run_spec(load_spec(SPEC))
    assert res.end == "done"
    assert res.load_t >= 0.9 * res.payload_t
    assert 5 <= len(res.passes) <= 12
    assert res.spill_m3 < 0.15 * sum(p.dumped_m3 for p in res.passes)
    assert abs(res.volume_drift_m3) < 1e-6


def test_bed_map_and_the_dump_choice():
    """The mind's bed map from the scanner's points holds the fill's volume, and the next dump goes to the
    emptier end of the bed, on its centre line."""
    from excavsim.tasks.truck_loading.mind import planner as plan

    bed = TruckBed(TruckSpec(), math.radians(34.0))
    t = bed.truck
    bed.catch(np.array([t.x_m - 1.5]), np.array([t.y_m]), np.array([1.0]), 0.6)  # a load at the -x end
    from excavsim.tasks.truck_loading.world.truck import BedScanner

    scanner = BedScanner(bed, np.array([t.x_m, t.y_m + 0.5 * t.width_m + 1.0, t.scanner_height_m]),
                         np.random.default_rng(0), noise_m=0.0)
    geom = plan.BedGeometry(t.x_m, t.y_m, t.heading, t.length_m, t.width_m, t.floor_m, cell_m=0.2)
    depth = plan.bed_map(scanner.scan(), geom)
    assert plan.map_volume(depth, geom) == pytest.approx(1.0, rel=0.15)
    x, y = plan.choose_dump(depth, geom, margin_m=1.0)
    assert x >= t.x_m + 0.2 and abs(y - t.y_m) <= 0.11  # off the heap, towards the empty +x end, on the centre line
    cx, cy, v = plan.deposit_centre(np.zeros_like(depth), depth, geom)
    assert cx == pytest.approx(t.x_m - 1.5, abs=0.3) and cy == pytest.approx(t.y_m, abs=0.2)


def test_the_learning_curve_from_campaign_episodes(tmp_path):
    import json

    from excavsim.tasks.truck_loading.figure import learning_curve

    eps = tmp_path / "episodes"
    eps.mkdir()
    for k, tuned in enumerate((True, False)):
        digs = [{"cost": 130.0 - (10.0 * i if tuned else 0.0), "cycle_s": 24.0 - (0.5 * i if tuned else 0.0),
                 "placement_error_cm": 20.0} for i in range(6)]
        rec = {"status": "ok", "summary": {"task": "truck_loading", "soil": "dry_sand", "tuned": int(tuned)},
               "digs": digs}
        (eps / f"e{k}.json").write_text(json.dumps(rec))
    text = learning_curve(tmp_path, tmp_path / "curve.png")
    assert (tmp_path / "curve.png").stat().st_size > 1000
    assert "dry_sand tuned: 1 runs; passes 1-3: cost 120.0" in text and "passes 4-6: cost 90.0" in text
    with pytest.raises(ConfigError, match="no truck_loading episode"):
        learning_curve(tmp_path / "nothing", tmp_path / "x.png")
