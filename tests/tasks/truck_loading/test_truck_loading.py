"""Rowe's truck loading with the 25 t excavator: the truck's volume account, the clearance angle of Fig. 3
against a hand derivation, AutoDig's pressure threshold, a one-pass episode and (slow) a full truck."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from excavsim.config.truck_loading import load_truck_loading_file
from excavsim.errors import ConfigError
from excavsim.execution import truck_loading as tl
from excavsim.loop.episode import Episode
from excavsim.loop.scenario import EpisodeSpec, resolve, episode_summary, load_spec, run_spec
from excavsim.robot.excavators import EXCAVATOR_25T
from excavsim.robot.extract import arm_from_model
from excavsim.tasks.truck_loading.task import TruckLoadingTask, truck_spec
from excavsim.world.hydraulics import EXCAVATOR_JOINTS
from excavsim.world.truck import TruckBed, TruckSpec, TruckWorld

SPEC = "configs/specs/excavator_truck.yaml"


@pytest.fixture(scope="module")
def world():
    return TruckWorld("excavator_25t", "dry_sand", seed=0)


@pytest.fixture(scope="module")
def arm25(world):
    return arm_from_model(world.model, joints=EXCAVATOR_JOINTS)


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


def test_clearance_angle_matches_the_hand_derivation(arm25):
    """Fig. 3 for the tip alone: z_f + A sin(theta + psi) = h + c with A e^(i psi) = l1 + l2 e^(i q2) +
    l3 e^(i (q2 + q3)), from the spec's link lengths and the truck's height."""
    a = EXCAVATOR_25T.arm
    h, c = TruckSpec().side_top_m, 0.3
    for q2, q3 in ((-1.7, -1.5), (-1.5, -1.8), (-1.9, -1.2)):
        v = a.boom_m + a.stick_m * np.exp(1j * q2) + a.bucket_m * np.exp(1j * (q2 + q3))
        hand = math.asin((h + c - a.boom_foot[1]) / abs(v)) - np.angle(v)
        got = tl.clearance_boom_angle(arm25, q2, q3, h, c, outline=False)
        assert got == pytest.approx(hand, abs=1e-9)
        # the whole bucket: its lowest point is exactly at h + c, and lower just below the angle
        full = tl.clearance_boom_angle(arm25, q2, q3, h, c)
        assert full >= got - 1e-12
        low = arm25.bucket_points(arm25.forward(np.array([full, q2, q3])))[:, 1].min()
        assert low == pytest.approx(h + c, abs=1e-9)
        assert arm25.bucket_points(arm25.forward(np.array([full - 0.01, q2, q3])))[:, 1].min() < h + c


def test_clearance_angle_in_mujoco(world, arm25):
    """The model's own bucket tip, posed at the tip-only clearance angle, is at the truck's height plus the clearance."""
    h, c, q2, q3 = TruckSpec().side_top_m, 0.3, -1.7, -1.5
    boom = tl.clearance_boom_angle(arm25, q2, q3, h, c, outline=False)
    d = mujoco.MjData(world.model)
    d.qpos[world._qpos] = [1.0, boom, q2, q3]
    mujoco.mj_kinematics(world.model, d)
    assert d.site_xpos[world.model.site("bucket_tip").id][2] == pytest.approx(h + c, abs=1e-6)


class _Rig:
    """A machine that goes where it is told at once, with a stick pressure set by how far the drag went."""

    control_dt = 0.02

    def __init__(self, arm, resist_after_m: float, x0: float):
        self.arm, self.q, self.resist, self.x0 = arm, np.array([0.0, 0.4, -1.2, -0.8]), resist_after_m, x0

    def joint_angles(self):
        return self.q.copy()

    def step(self, target):
        self.q = np.asarray(target, float).copy()
        return self.q.copy()

    def cylinder_pressures(self):
        x = float(self.arm.forward(self.q[1:])[0])
        return np.array([5e6, -40e6 if self.x0 - x > self.resist else -5e6, 5e6])


def test_autodig_ends_the_drag_on_the_stick_pressure(arm25):
    cfg = tl.AutoDigConfig(depth_m=0.4, drag_m=3.0, full_pa=30e6, full_s=0.3)
    run = tl.autodig(_Rig(arm25, 1.0, 7.5), arm25, 0.0, 7.5, lambda r: 0.0, cfg)
    assert run.drag_end == "stick pressure (full)"
    assert 1.0 < run.drag_m < 1.8  # the filter's lag and the hold time past the 1 m where resistance rose
    easy = tl.autodig(_Rig(arm25, 10.0, 7.5), arm25, 0.0, 7.5, lambda r: 0.0, cfg)
    assert easy.drag_end == "length" and easy.drag_m == pytest.approx(3.0, abs=0.05)


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
    from excavsim.planning import truck_loading as plan

    bed = TruckBed(TruckSpec(), math.radians(34.0))
    t = bed.truck
    bed.catch(np.array([t.x_m - 1.5]), np.array([t.y_m]), np.array([1.0]), 0.6)  # a load at the -x end
    from excavsim.world.truck import BedScanner

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
