"""Loading in MuJoCo: the loader and shovel models, their kinematics against robot/loaders.py, a planned dig's
shaping and reachability in MuJoCo, the volume account of an episode, and short episodes with both machines."""

from __future__ import annotations

import importlib.util
import math

import mujoco
import numpy as np
import pytest
from dm_control import mjcf

from excavsim import cli, constants
from excavsim.errors import ExcavsimError
from excavsim.tasks.pile_loading import planar as ld
from excavsim.tasks.pile_loading import task as lm
from excavsim.tasks.pile_loading.config import load_loading_campaign
from excavsim.tasks.pile_loading.mind import planner as lp
from excavsim.tasks.pile_loading.world import scene as ls
from excavsim.tasks.pile_loading.world.pile2d import trapezoid_pile

MACHINES = ("loader", "shovel")


@pytest.fixture(scope="module")
def cfg2d():
    return ld.load_loading_config()


def _model(name):
    physics = mjcf.Physics.from_mjcf_model(ls.build_loading_scene(name))
    return physics.model.ptr


def _tip(model, data):
    sid = model.site(constants.BUCKET_TIP_SITE).id
    p = data.site_xpos[sid]
    x_axis = data.site_xmat[sid].reshape(3, 3)[:, 0]
    return np.array([p[0], p[2], math.atan2(x_axis[2], x_axis[0])])


def _wrap(a):
    return (np.asarray(a) + math.pi) % (2 * math.pi) - math.pi


@pytest.mark.parametrize("name", MACHINES)
def test_scene_compiles_and_one_second_of_noisy_control_raises_no_warning(name):
    model = _model(name)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("carry").id)
    rng = np.random.default_rng(0)
    base = data.ctrl.copy()
    for _ in range(500):
        data.ctrl[:] = base + rng.normal(0.0, 0.05, model.nu)
        mujoco.mj_step(model, data)
    assert all(w.number == 0 for w in data.warning)
    assert np.all(np.isfinite(data.qpos))


def test_models_match_their_generator():
    spec = importlib.util.spec_from_file_location("make_loading_models",
                                                  constants.REPO_ROOT / "scripts" / "make_loading_models.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    for path, text in gen.generated().items():
        assert path.read_text() == text, f"{path} is stale: run scripts/make_loading_models.py"


@pytest.mark.parametrize("name", MACHINES)
def test_mujoco_kinematics_of_the_mjcf_equal_the_closed_forms(name, cfg2d):
    """mj_kinematics of the MJCF model at random joint values within the limits: the bucket tip site's (x, z)
    and floor direction equal robot/loaders.py's closed forms (the loader's also its Table A1-3 DH product)."""
    machine = ld.make_machine(cfg2d, name)
    model = _model(name)
    data = mujoco.MjData(model)
    joints = ls.MACHINE_JOINTS[name]
    adr = [model.jnt_qposadr[model.joint(j).id] for j in joints]
    lo, hi = machine.lower, machine.upper
    # the MJCF limits are the machine's (the loader's travel d1 and two angles; the shovel's three angles)
    np.testing.assert_allclose(model.jnt_range[[model.joint(j).id for j in joints[-3:]]], np.stack([lo, hi], 1),
                               atol=1e-6)
    rng = np.random.default_rng(1)
    for _ in range(50):
        q = rng.uniform(lo, hi)
        base_x = rng.uniform(-3, 3)
        full = q if name == "loader" else np.r_[base_x, q]
        data.qpos[adr] = full
        mujoco.mj_kinematics(model, data)
        got = _tip(model, data)
        want = machine.forward(q) if name == "loader" else machine.forward(q, base_x)
        np.testing.assert_allclose(got[:2], want[:2], atol=1e-9)
        assert abs(_wrap(got[2] - want[2])) < 1e-9
        assert abs(data.site_xpos[model.site(constants.BUCKET_TIP_SITE).id][1]) < 1e-12  # the plane y = 0
        if name == "loader":
            t = machine.forward_dh(q)
            np.testing.assert_allclose([t[0, 3], t[1, 3]], got[:2], atol=1e-9)


@pytest.mark.parametrize("name", MACHINES)
def test_a_planned_loading_dig_is_shaping_and_reachable_by_ik_and_in_mujoco(name, cfg2d):
    """A dig planned on a pile: every dense pose of its path has an IK solution within the MJCF joint ranges,
    MuJoCo's kinematics at those joints put the tip on the planned pose, and no tip point is below the ground
    (shaping, within the planner's tolerance)."""
    machine = ld.make_machine(cfg2d, name)
    spec = getattr(cfg2d.machines, name)
    rules = ld.make_rules(cfg2d, spec.capacity_units)
    pile = trapezoid_pile(1.5, 0.8, 1.5, 8.5, 0.05, 30.0)
    terrain = ld.terrain_of(pile)
    plan = lp.plan(machine, terrain, rules)
    assert plan.action is not None and plan.volume > 0.5 * rules.capacity
    poses, phase = lm.dig_poses(plan.action, terrain, rules, machine.floor, step=0.02, lift_extra=0.3)
    dug = phase >= 0  # not the pre-entry
    q, kept_slice = lm.joint_path(machine, poses, plan.base_x)
    model = _model(name)
    data = mujoco.MjData(model)
    joints = ls.MACHINE_JOINTS[name]
    jid = [model.joint(j).id for j in joints]
    assert np.all(q >= model.jnt_range[jid, 0] - 1e-9) and np.all(q <= model.jnt_range[jid, 1] + 1e-9)
    tips = []
    for qq in q:
        data.qpos[[model.jnt_qposadr[j] for j in jid]] = qq
        mujoco.mj_kinematics(model, data)
        tips.append(_tip(model, data))
    tips = np.array(tips)
    kept = poses[kept_slice]
    np.testing.assert_allclose(tips[:, :2], kept[:, :2], atol=1e-9)
    assert np.all(np.abs(_wrap(tips[:, 2] - kept[:, 2])) < 1e-9)
    # every pose of the approach and the arc is reachable, and the lift-out's up to the planner's clearance
    cut = np.flatnonzero(dug & (phase < 2))
    assert kept_slice.start <= cut[0] and cut[-1] < kept_slice.stop
    assert kept_slice.stop >= len(poses) - int(0.3 / 0.02)
    assert tips[:, 1].min() >= -rules.tolerance
    # the bucket pin stays above the ground and on the bucket's side of its floor (mu < 0: a real bucket's pin is
    # above its floor's line; with mu = +20 deg it passed 0.3 m under the ground in digs along it)
    joints = q if name == "loader" else q[:, 1:]
    pts = machine.points(joints) if name == "loader" else machine.points(joints, q[:, 0])
    pin = pts[:, -2]
    assert pin[:, 1].min() > 0.1
    normal = np.stack([-np.sin(kept[:, 2]), np.cos(kept[:, 2])], axis=1)  # the floor's normal into the bucket
    assert np.all(np.einsum("ij,ij->i", pin - kept[:, :2], normal) > 0.2)
    # and a pose beyond the machine's reach within the dig is refused, not silently clipped
    far = poses.copy()
    far[cut[len(cut) // 2], 1] += 10.0  # 10 m up: beyond both machines
    with pytest.raises(ExcavsimError, match="out of the machine's reach"):
        lm.joint_path(machine, far, plan.base_x)


@pytest.mark.parametrize("name", MACHINES)
def test_a_short_mujoco_episode_removes_a_small_pile_and_conserves_volume(name):
    """A small pile, removed to tolerance through the whole loop (scan, plan, script, settle); the lane, the
    bucket, the delivered and the spilled soil hold the pile's volume at every control step, to round-off, and
    the delivered soil is what the bucket carried (never more than it held at lift-out)."""
    drift = []
    account = lm.SoilAccount()

    def check(world):
        v = world.volumes()
        drift.append(v.box + v.bucket + account.delivered + account.spilled - world.soil.initial_volume)
        assert abs(account.delivered + account.spilled - v.spoil) < 1e-12

    run = lm.run_loading_episode(name, pile=lm.PileLane(height=0.6, top=0.3, foot=1.5), max_digs=6, world_hooks=[check],
                         account=account)
    assert run.done, lm.format_run(run)
    assert "no pile left" in run.reason
    assert len(drift) > 1000
    assert max(abs(d) for d in drift) < 1e-9 * run.start_m3
    assert abs(run.start_m3 - run.end_m3 - run.delivered_m3 - run.spilled_m3) < 1e-9
    full = [d for d in run.digs if d.planned_m3 > 0.8 * run.capacity_m3]
    assert full, "no full dig"
    for d in full:  # a full planned dig fills the bucket in the world, within 15 %
        assert abs(d.bucket_m3 - d.planned_m3) < 0.15 * d.planned_m3
    for d in run.digs:
        assert d.delivered_m3 <= d.bucket_m3 + 1e-12
        assert d.delivered_m3 > 0.9 * d.bucket_m3  # the dump empties the bucket at the truck
    assert run.efficiency() <= 1.0


def test_soil_pushed_off_the_lane_counts_as_spilled_not_delivered():
    """The account splits the world's spoil by phase: growth while dumping is delivered, any other is spilled
    (a bulldozing dig that pushes soil over the lane's end), and the two always add up to the spoil."""
    world = ls.LoadingWorld("loader")
    account = lm.SoilAccount()
    account.reset(world)
    world.soil.spoil += 0.3  # soil leaves the lane while the bucket digs
    account(world)
    account.dumping = True
    world.soil.spoil += 0.2  # the bucket pours at the truck
    account(world)
    account.dumping = False
    assert account.spilled == pytest.approx(0.3) and account.delivered == pytest.approx(0.2)
    assert account.delivered + account.spilled == pytest.approx(world.volumes().spoil)


def test_soil_off_the_middle_section_is_still_the_pile():
    """A map whose soil lies only along the far kerb: the middle section is bare, but the episode's end
    condition sees the soil in the map and the planner digs the far side's section."""
    from excavsim.handoff.maps import ElevationMap

    cfg, cfg2d = lm.load_mujoco_config(), ld.load_loading_config()
    machine = ld.make_machine(cfg2d, "loader")
    rules = ld.make_rules(cfg2d, cfg2d.machines.loader.capacity_units)
    ny, nx, cell = 18, 170, 0.05
    xs = (np.arange(nx) + 0.5) * cell
    ys = -0.45 + (np.arange(ny) + 0.5) * cell
    ridge = np.clip(0.5 - np.abs(xs - 3.0) * math.tan(math.radians(30.0)), 0.0, None)
    heights = np.where((ys >= cfg.section_half_width)[:, None], ridge[None, :], 0.0)
    emap = ElevationMap(0.0, -0.45, cell, heights, np.ones((ny, nx), bool), 0.0)
    sections = lm.map_sections(emap, cfg.section_half_width)
    assert set(sections) == set(lm.SECTIONS)
    assert lp.plan(machine, sections["middle"], rules).action is None  # the middle alone says "no pile"
    assert lm.map_soil_m3(emap, 0.95, rules.ground) > 0.05
    name, terrain, plan = lm.choose_section(machine, sections, rules)
    assert name == "far side" and plan.action is not None
    assert plan.volume > rules.min_fraction * rules.capacity
    bare = ElevationMap(0.0, -0.45, cell, np.zeros((ny, nx)), np.ones((ny, nx), bool), 0.0)
    name, _, plan = lm.choose_section(machine, lm.map_sections(bare, cfg.section_half_width), rules)
    assert plan.action is None and plan.reason == "no pile left"
    assert lm.map_soil_m3(bare, 0.95, rules.ground) == 0.0


def test_bad_machine_config_and_arguments_are_refused(tmp_path, capsys):
    with pytest.raises(ExcavsimError, match="allowed: loader, shovel"):
        ls.LoadingWorld("excavator")
    bad = tmp_path / "bad.yaml"
    text = lm.CONFIG_PATH.read_text().replace("joint_speed: [1.0, 0.35, 0.7]", "joint_speed: [1.0, 0.35]")
    bad.write_text(text)
    with pytest.raises(ExcavsimError, match="script.loader.joint_speed"):
        lm.load_mujoco_config(bad)
    assert cli.main(["load", "--record", str(tmp_path / "x.rrd")]) == 2
    assert "--record needs --mujoco" in capsys.readouterr().err
    assert cli.main(["load", "--mujoco", "--record", str(tmp_path / "x.rrd")]) == 2
    assert "give --machine" in capsys.readouterr().err
    with pytest.raises(ExcavsimError, match="beyond the lane"):
        lm.run_loading_episode("loader", pile=lm.PileLane(height=2.0, top=3.0, foot=1.5))
    camp = tmp_path / "camp.yaml"
    camp.write_text("machines: [loader, excavator]\nseeds: [0, 1]\n")
    assert cli.main(["load", "--campaign", str(camp)]) == 2  # refused before any episode runs
    assert "allowed: loader, shovel" in capsys.readouterr().err
    camp.write_text("machines: [loader]\nseeds: [0, 0]\n")
    assert cli.main(["load", "--campaign", str(camp)]) == 2
    assert "distinct" in capsys.readouterr().err
    assert cli.main(["load", "--campaign", str(constants.CONFIGS_DIR / "campaigns" / "pile_loading_machines.yaml"),
                     "--machine", "loader"]) == 2
    assert "--campaign runs the machines" in capsys.readouterr().err
    campaign = load_loading_campaign(constants.CONFIGS_DIR / "campaigns" / "pile_loading_machines.yaml")
    assert campaign.seeds == list(range(8))


def test_a_recorded_loading_episode_passes_rerun_verify_and_holds_its_entities(tmp_path):
    import pathlib
    import shutil
    import subprocess
    import sys
    from collections import defaultdict

    from rerun.chunk import RrdReader

    from excavsim.tasks.pile_loading.recording import LoadingRecorder

    path = tmp_path / "load.rrd"
    run = lm.run_loading_episode("loader", pile=lm.PileLane(height=0.6, top=0.3, foot=1.5), max_digs=1,
                         observer=LoadingRecorder(path))
    here = pathlib.Path(sys.executable).parent / "rerun"
    exe = str(here) if here.exists() else shutil.which("rerun")
    assert exe is not None, "the rerun CLI (installed with rerun-sdk) is missing"
    done = subprocess.run([exe, "rrd", "verify", str(path)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    tree: dict[str, dict] = defaultdict(lambda: defaultdict(int))
    for chunk in RrdReader(path).stream().to_chunks():
        for key in (["static"] if chunk.is_static else list(chunk.timeline_names)):
            tree[chunk.entity_path][key] += chunk.num_rows
    for body in ("chassis", "boom", "bucket"):  # a pose per sample at 10 Hz of simulated time
        assert tree[f"/world/loader/{body}"]["sim_time"] == pytest.approx(10 * run.sim_time_s, rel=0.05)
    assert tree["/world/loader/bucket/bucket_floor"]["static"] == 1
    assert tree["/world/soil/truth"]["static"] == 1
    for temporal in ("/world/soil/scan", "/world/plan/path", "/world/exec/path", "/volumes/total_m3",
                     "/volumes/spoil_m3", "/truth/soil_force_n", "/joints/boom", "/log"):
        assert tree[temporal]["sim_time"] >= 1, temporal


def test_a_divergence_ends_the_episode_with_its_reason_instead_of_a_crash():
    from excavsim.errors import Diverged

    count = {"n": 0}

    def blow_up(world):
        count["n"] += 1
        if count["n"] == 200:
            raise Diverged("MuJoCo warned (a test's stand-in)")

    run = lm.run_loading_episode("loader", pile=lm.PileLane(height=0.6, top=0.3, foot=1.5), world_hooks=[blow_up])
    assert run.digs == [] and "dig 1: MuJoCo warned" in run.reason
    assert not run.done


def test_loading_is_a_task_of_the_episode_spec_and_the_stepped_episode():
    from excavsim.config import ConfigError
    from excavsim.loop.catalog import plugin
    from excavsim.loop.scenario import EpisodeSpec, dig_rows, episode_summary, run_spec, spec_episode

    assert plugin("pile_loading").machines == tuple(MACHINES)
    with pytest.raises(ConfigError, match="unknown task 'dig'; registered here: trench, pile_loading"):
        EpisodeSpec(task="dig")
    with pytest.raises(ConfigError, match="machine 'loader' does not do task trench; allowed: t3"):
        EpisodeSpec(machine="loader")
    with pytest.raises(ConfigError, match="task pile_loading does not use goal .a field of task trench"):
        EpisodeSpec(task="pile_loading", goal="small", planner={"objective": "volume"})
    with pytest.raises(ConfigError, match="task trench does not use pile_loading .a field of task pile_loading"):
        EpisodeSpec(pile_loading={"n_scans": 2})
    with pytest.raises(ConfigError, match="loading: task pile_loading calls it pile_loading now"):
        EpisodeSpec(task="pile_loading", loading={"n_scans": 2})
    with pytest.raises(ConfigError, match="n_scans"):
        run_spec(EpisodeSpec(task="pile_loading", pile_loading={"n_scans": 0}))

    fields = {"task": "pile_loading", "machine": "shovel", "seed": 1, "dig_budget": 2,
              "pile_loading": {"pile": {"height": 0.6, "top": 0.3, "foot": 1.5}, "n_scans": 2}}
    spec = EpisodeSpec.model_validate(EpisodeSpec(**fields).model_dump(mode="json"))  # a campaign's round trip
    assert spec.machine_name == "shovel" and EpisodeSpec(task="pile_loading").machine_name == "loader"
    class Hooks:  # one observer protocol: the episode's six hooks, with the loading task's arguments
        def __init__(self):
            self.calls = []

        def started(self, world, machine):
            self.calls.append(("started", machine))

        def scanned(self, index, emap, terrain):
            self.calls.append(("scanned", index))

        def planned(self, index, plan, tip_path):
            self.calls.append(("planned", index))

        def stepped(self, world):
            pass

        def dug(self, index, dig):
            self.calls.append(("dug", index))

        def finished(self, run):
            self.calls.append(("finished", run.end))

    from excavsim.handoff.episode import ObserverGroup

    one, two = Hooks(), Hooks()
    whole = run_spec(spec, observer=ObserverGroup(one, two))
    assert one.calls == two.calls and one.calls[:4] == [("started", "shovel"), ("scanned", 1), ("planned", 1),
                                                        ("dug", 1)]
    assert one.calls[-1] == ("finished", whole.end)
    direct = lm.run_loading_episode("shovel", seed=1, max_digs=2, cfg=lm.load_mujoco_config().model_copy(
        update={"pile": lm.PileLane(height=0.6, top=0.3, foot=1.5), "n_scans": 2}))
    assert [d.bucket_m3 for d in whole.digs] == [d.bucket_m3 for d in direct.digs]  # the same episode, bit for bit
    assert whole.end == direct.end and whole.reason == direct.reason and whole.end in ("done", "budget")

    ep = spec_episode(spec)  # the same episode, one phase at a time
    ep.reset(spec.seed)
    emap = ep.look()
    assert emap is not None and not ep.over
    choice = ep.decide()
    assert choice.plan.action is not None and choice.dig.shape[1] >= 2  # the planned tip path
    (dig,) = ep.dig()
    assert dig.bucket_m3 == whole.digs[0].bucket_m3
    result = ep.run()
    summary = episode_summary(result)
    assert summary["task"] == "pile_loading" and summary["machine"] == "shovel" and summary["digs"] == len(whole.digs)
    assert summary["end"] == whole.end and abs(summary["volume_change_m3"]) < 1e-9
    assert 0 < summary["removed_fraction"] <= 1 and summary["wall_s"] > 0
    rows = dig_rows(result)
    assert len(rows) == len(whole.digs) and rows[0]["dug_l"] == pytest.approx(1000 * whole.digs[0].bucket_m3)


def test_excavsim_trench_runs_a_loading_spec(tmp_path, capsys):
    from excavsim.cli import main

    spec = tmp_path / "load.yaml"
    spec.write_text("task: pile_loading\nmachine: loader\ndig_budget: 1\n"
                    "pile_loading: {pile: {height: 0.6, top: 0.3, foot: 1.5}, n_scans: 2}\n")
    assert main(["trench", "--spec", str(spec), "--save-maps", str(tmp_path / "maps")]) == 2
    assert "--save-maps: task pile_loading does not take it; it takes --record" in capsys.readouterr().err
    assert main(["trench", "--spec", str(spec), "--goal", "small"]) == 2
    assert "the specification's task is pile_loading, which has no trench goal" in capsys.readouterr().err
    rrd = tmp_path / "x.rrd"
    assert main(["trench", "--spec", str(spec), "--record", str(rrd)]) == 0
    out = capsys.readouterr().out
    assert "task pile_loading, machine loader, 1 digs at most" in out and "1 digs spent" in out
    assert f"recorded to {rrd}" in out
    from excavsim.record.replay import check_recording

    check_recording(str(rrd))  # a recording the installed Rerun loads (rerun rrd verify)


def test_a_campaign_grid_varies_the_loading_machine_and_its_configuration():
    from excavsim.config import ConfigError
    from excavsim.studies.campaign.grid import expand_grid, parse_campaign

    data = {"name": "loads", "base": {"task": "pile_loading", "dig_budget": 2, "pile_loading": {"n_scans": 2}},
            "grid": {"machine": ["loader", "shovel"], "pile_loading.pile.height": [0.6, 0.8], "seed": [0]}}
    episodes = expand_grid(parse_campaign(data))
    assert len({e.id for e in episodes}) == 4
    assert {(e.spec.machine_name, e.spec.options.pile_loading["pile"]["height"],
             e.spec.options.pile_loading["n_scans"]) for e in episodes} == \
        {(m, h, 2) for m in ("loader", "shovel") for h in (0.6, 0.8)}
    with pytest.raises(ConfigError, match=r"grid key 'pile_loading.n_scans', value 0:(.|\n)*n_scans"):
        parse_campaign({**data, "grid": {"pile_loading.n_scans": [0]}})
    with pytest.raises(ConfigError, match="grid key 'loading.n_scans': loading is called pile_loading now"):
        parse_campaign({**data, "grid": {"loading.n_scans": [0]}})
    with pytest.raises(ConfigError, match="machine 't3' does not do task pile_loading"):
        parse_campaign({**data, "grid": {"machine": ["t3"]}})
