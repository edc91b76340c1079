"""The parameterized-script executor: the engine's triggers, the dig script, touch-down, stalls."""

from __future__ import annotations

import numpy as np
import pytest

from excavsim import constants
from excavsim.config import get_soil, load_executor_config, load_planner_config, load_robot_config, load_trench_goal
from excavsim.execution.conditions import (Context, Sense, after, all_of, always, any_of, event, force_above,
                                           force_below, held, joint_above, past, path_done, reached, started,
                                           timed_out)
from excavsim.execution.dig import DigExecutor, dig_script
from excavsim.execution.script import Abort, Command, Script, ScriptEngine, Step, SubScript, Watch
from excavsim.handoff.dig import DigPlan
from excavsim.handoff.maps import ElevationMap
from excavsim.rig.core import bucket_witness
from excavsim.planning.predictor import WedgePredictor
from excavsim.planning.search import TrenchPlanner
from excavsim.sensing.ft import ForceSensor
from excavsim.world.simulation import Simulation

JOINTS = list(constants.JOINTS)


def sense(t, q=None, force=0.0, events=()):
    q = dict(zip(JOINTS, q if q is not None else np.zeros(6)))
    zeros = dict.fromkeys(JOINTS, 0.0)
    return Sense(t, q, zeros, zeros, np.array([force, 0.0, 0.0]), frozenset(events))


def test_engine_triggers_fire_in_order_on_a_synthetic_stream():
    """Rowe & Stentz's coupling: the waist swings when the shoulder passes an angle; other steps wait
    for time, a force, an event and for a joint to reach its command."""
    boom = SubScript(("shoulder_joint",), (
        Step("dig", always(), Command((0.1,))),
        Step("raise", force_above(100.0), Command((0.6,))),
        Step("hold", all_of(reached("shoulder_joint", 0.01), after(0.5)), Command()),
    ))
    swing = SubScript(("waist_joint",), (
        Step("stay", always(), Command((0.0,))),
        Step("swing", joint_above("shoulder_joint", 0.4), Command((1.0,))),
        Step("back", event("dumped"), Command((0.0,))),
    ))
    engine = ScriptEngine(Script("synthetic", (boom, swing)))
    stream = [  # time, shoulder angle, F/T force, events
        (0.0, 0.0, 0.0, ()), (0.1, 0.1, 50.0, ()), (0.2, 0.1, 150.0, ()), (0.3, 0.3, 0.0, ()), (0.4, 0.45, 0.0, ()),
        (0.5, 0.6, 0.0, ()), (0.8, 0.6, 0.0, ()), (1.1, 0.6, 0.0, ()), (1.2, 0.6, 0.0, ("dumped",)),
    ]
    for t, sh, f, ev in stream:
        q = np.zeros(6)
        q[1] = sh
        engine.tick(sense(t, q, f, ev))
    order = [(tr.time, tr.name) for tr in engine.transitions]
    assert order == [(0.0, "dig"), (0.0, "stay"), (0.2, "raise"), (0.4, "swing"), (0.8, "hold"), (1.2, "back")]
    assert engine.finished
    assert engine.targets == {"shoulder_joint": 0.6, "waist_joint": 0.0}
    assert "when shoulder_joint > 0.4 -> go to 57.3 deg" in engine.script.describe()


def evaluate(cond, stream, step_time0=0.0):
    """Evaluate ``cond`` on a stream of (time, F/T force) as the engine does within one step (its
    memory kept from tick to tick); returns whether it held on each tick."""
    ctx = Context("step", 0.0, {})
    out = []
    for t, f in stream:
        ctx.step_time = t - step_time0
        out.append(cond.holds(sense(t, force=f), ctx))
    return out


def test_a_force_held_for_two_ticks_does_not_fire_a_three_tick_condition_three_do():
    cond = held(force_above(100.0), ticks=3)
    stream = [(0.0, 150.0), (0.1, 150.0), (0.2, 50.0), (0.3, 150.0), (0.4, 150.0), (0.5, 150.0), (0.6, 150.0)]
    assert evaluate(cond, stream) == [False, False, False, False, False, True, True]
    assert cond.describe() == "|F| > 100 N for 3 ticks"


def test_a_force_held_for_a_duration_counts_from_the_first_tick_it_held():
    cond = held(force_below(40.0), seconds=0.5)
    stream = [(0.0, 10.0), (0.3, 10.0), (0.4, 90.0), (0.5, 10.0), (0.9, 10.0), (1.0, 10.0), (1.1, 10.0)]
    assert evaluate(cond, stream) == [False, False, False, False, False, True, True]


def test_a_condition_that_is_not_yet_eligible_does_not_count():
    """Touch-down: the F/T counts for contact only once the descent has run 0.3 s, however high it is before."""
    cond = all_of(past(0.3), held(force_above(100.0), ticks=3))
    stream = [(0.0, 500.0), (0.1, 500.0), (0.2, 500.0), (0.3, 500.0), (0.4, 500.0), (0.5, 500.0), (0.6, 500.0)]
    assert evaluate(cond, stream) == [False, False, False, False, False, False, True]  # 0.3 s is not past 0.3 s
    assert cond.describe() == "(past 0.3 s and |F| > 100 N for 3 ticks)"


def test_a_gate_that_stops_holding_pauses_a_held_condition():
    """``all_of`` stops at the first condition that fails: the ``held`` after it keeps its count."""
    gate = event("settled")
    cond = all_of(gate, held(force_below(40.0), seconds=0.5))
    ctx = Context("dump", 0.0, {})
    ticks = [(0.0, ("settled",)), (0.3, ()), (0.4, ("settled",)), (0.5, ("settled",))]
    assert [cond.holds(sense(t, events=ev), ctx) for t, ev in ticks] == [False, False, False, True]


def seek_and_dig(timeout_s=None):
    """A touch-down in miniature: seek until contact (3 ticks above 100 N), abort when the descent ends
    empty, dig, then stop when the joint has settled or the dig timed out."""
    return Script("mini", (SubScript(("shoulder_joint",), (
        Step("seek", always(), Command(path="down", speed=0.1, tol=0.01),
             watches=(Watch("contact", held(force_above(100.0), ticks=3)),),
             abort=Abort("no contact", event("path_end:down"), "nothing found")),
        Step("dig", event("contact"), Command((0.5,)), timeout_s,
             ends=any_of(reached("shoulder_joint", 0.01), timed_out())),
    )), SubScript(("waist_joint",), (
        Step("wait", always(), Command((0.0,))),
        Step("swing", started("dig"), Command((1.0,))),
    ))))


def tick(engine, t, force=0.0, shoulder=0.0, at_end=False):
    """One control tick of ``engine`` as the executor runs it; returns the step names after it."""
    q = np.zeros(6)
    q[1] = shoulder
    s = sense(t, q, force)
    commands = engine.tick(s)
    if engine.stop is None:
        if commands[0].path:
            engine.report(0, [shoulder], at_end=at_end)
        engine.end_tick(s)
    return [engine.current(i).name for i in range(2)]


def test_a_watch_raises_its_event_at_the_end_of_a_tick_and_the_script_moves_on_the_next():
    engine = ScriptEngine(seek_and_dig())
    steps = [tick(engine, 0.1 * k, f) for k, f in enumerate([0.0, 150.0, 150.0, 150.0, 0.0, 0.0])]
    assert "contact" in engine.events
    assert steps == [["seek", "wait"]] * 4 + [["dig", "wait"], ["dig", "swing"]]  # the waist sees "started:dig" later
    assert [(tr.time, tr.name) for tr in engine.transitions][2:] == [(pytest.approx(0.4), "dig"),
                                                                      (pytest.approx(0.5), "swing")]


def test_an_abort_stops_the_script_on_the_tick_after_the_path_ended():
    engine = ScriptEngine(seek_and_dig())
    tick(engine, 0.0)
    tick(engine, 0.1, at_end=True)  # the path ends: the abort sees it from the next tick
    assert engine.stop is None
    tick(engine, 0.2, at_end=True)
    assert engine.stop is not None and engine.stop.kind == "abort" and engine.stop.abort.outcome == "no contact"
    assert engine.stop.step == "seek" and engine.stop.time == pytest.approx(0.2)


def test_a_step_ends_the_script_when_settled_or_once_it_timed_out():
    engine = ScriptEngine(seek_and_dig())
    for k, f in enumerate([150.0, 150.0, 150.0]):
        tick(engine, 0.1 * k, f)
    tick(engine, 0.3, shoulder=0.2)  # moves to dig, far from 0.5
    assert engine.stop is None
    tick(engine, 0.4, shoulder=0.495)
    assert engine.stop.kind == "end" and engine.stop.step == "dig" and not engine.timeouts

    engine = ScriptEngine(seek_and_dig(timeout_s=1.0))
    for k, f in enumerate([150.0, 150.0, 150.0]):
        tick(engine, 0.1 * k, f)
    tick(engine, 0.3, shoulder=0.2)
    tick(engine, 1.2, shoulder=0.2)
    assert engine.stop is None and not engine.timeouts
    tick(engine, 1.4, shoulder=0.2)  # 1.1 s in a step that times out after 1 s
    assert [t.name for t in engine.timeouts] == ["dig"] and engine.stop.kind == "end"


def test_a_path_command_is_done_at_its_end_once_its_joints_settle():
    script = Script("path", (SubScript(("shoulder_joint",), (
        Step("go", always(), Command(path="p", speed=0.1, tol=0.01)),
        Step("next", path_done("p"), Command()),
    )),), timeout_s=2.0)
    engine = ScriptEngine(script)
    q = np.zeros(6)
    for t, at_end, target in [(0.0, False, 0.3), (0.1, True, 0.3), (0.2, True, 0.005)]:
        engine.tick(sense(t, q))
        engine.report(0, [target], at_end=at_end)
        engine.end_tick(sense(t, q))
        assert ("path_done:p" in engine.events) == (t == 0.2)
    engine.tick(sense(0.3, q))
    assert engine.current(0).name == "next"
    engine.tick(sense(2.05, q))
    engine.end_tick(sense(2.05, q))
    assert engine.stop.kind == "timeout" and engine.stop.step == "next"


def test_the_dig_script_describes_every_step_and_condition(flat_run, arm):
    sim, plan, _ = flat_run
    cfg = load_executor_config()
    script = dig_script(plan, arm, cfg, sim.index.park)
    text = script.describe()
    names = [st.name for sub in script.subscripts for st in sub.steps]
    assert names == ["above entry", "touch-down", "dig", "lift out", "hold lifted", "over spoil", "dump", "park",
                     "dig plane", "swing to spoil", "swing to park", "level"]
    for sub in script.subscripts:
        for st in sub.steps:
            assert f"{st.name}: when {st.when.describe()} -> {st.command.describe()}" in text
            for w in st.watches:
                assert f"raises {w.event} when {w.when.describe()}" in text
            if st.abort is not None:
                assert f"aborts {st.abort.outcome!r} when {st.abort.when.describe()}" in text
            if st.ends is not None:
                assert f"ends the script when {st.ends.describe()}" in text
    for part in ["raises contact when (past 0.3 s and |F| > 120 N for 3 ticks)",
                 "|F| < 40 N for 0.5 s", "times out after 20 s", "stops after 160 s", "follow dig at 0.15 m/s",
                 "aborts 'no contact' when (event path_end:touchdown and", "swing to spoil: when (event path_done:lift "
                 "or event started:hold lifted)"]:
        assert part in text, part
    assert text.count("times out after 20 s") == 8  # every arm step


def run_dig(sim, arm, cfg, plan):
    """Execute ``plan`` as the loop does: F/T at the tip, the model's park pose, the bucket measured at lift-out."""
    return DigExecutor(sim, arm, cfg, ForceSensor(sim.model), sim.index.park).run(plan, on_phase=bucket_witness(sim))


def flat_map(z=0.5):
    return ElevationMap(0.55, -1.5, 0.05, np.full((60, 60), z), np.ones((60, 60), bool), 0.0)


def planned_dig(sim, arm, table, emap, soil="testbed_sand"):
    s = get_soil(soil)
    planner = TrenchPlanner(arm, table, sim.torque_limit[1:4], 0.3, 0.0204, load_trench_goal(
        constants.TRENCHES_DIR / "straight.yaml"), load_planner_config(), WedgePredictor(s, 0.3), s.density_kg_m3)
    res = planner.plan(emap)
    assert res.action is not None
    return DigPlan(res.poses, res.phases, 0.0, res.volume_m3)


@pytest.fixture(scope="module")
def flat_run(arm, reach_table):
    sim = Simulation(seed=0)
    plan = planned_dig(sim, arm, reach_table, flat_map())
    rec = run_dig(sim, arm, load_executor_config(), plan)
    return sim, plan, rec


def test_a_planned_dig_in_flat_sand_follows_its_path(flat_run):
    sim, plan, rec = flat_run
    assert rec.completed, (rec.outcome, rec.warnings)
    assert rec.path_error() < 0.03  # the servos track the planned tip path within 3 cm under load
    assert rec.bucket_volume_m3 > 0.8 * plan.volume_m3  # soil actually in the bucket at lift-out
    assert sim.truth.volumes.bucket == pytest.approx(0.0, abs=1e-9)  # dumped
    assert abs(sim.truth.volumes.total - sim.soil.initial_volume) < 1e-12 * sim.soil.initial_volume
    assert set(rec.phase_times) >= {"above entry", "touch-down", "dig", "lift out", "dump", "park"}
    assert len(rec.ft) > 100 and rec.stall is None


@pytest.mark.parametrize("bias", [0.05, -0.05])
def test_touch_down_finds_the_surface_when_the_map_is_biased(arm, reach_table, bias):
    """§7.1.3: the offset between planned and found contact estimates the map's error; the dig moves
    by it, at most ``touch_shift_max_m``."""
    sim = Simulation(seed=1)
    plan = planned_dig(sim, arm, reach_table, flat_map(0.5 + bias))
    cfg = load_executor_config()
    rec = run_dig(sim, arm, cfg, plan)
    assert rec.touch_offset_m == pytest.approx(-bias, abs=0.03)
    shift = np.clip(rec.touch_offset_m, -cfg.touch_shift_max_m, cfg.touch_shift_max_m)
    assert rec.planned_path[0, 1] == pytest.approx(plan.poses[0, 1] + shift)  # the dig moved, within the cap
    assert rec.outcome in ("completed", "stalled")
    uncapped = cfg.model_copy(update={"touch_shift_max_m": 1.0})
    sim = Simulation(seed=1)
    rec = run_dig(sim, arm, uncapped, plan)
    assert rec.planned_path[0, 1] == pytest.approx(plan.poses[0, 1] + rec.touch_offset_m)  # the whole offset


def test_a_touch_down_that_finds_nothing_aborts_and_parks(arm, reach_table):
    """The descent ends settled without contact (a force threshold no sand reaches): the script aborts."""
    sim = Simulation(seed=2)
    plan = planned_dig(sim, arm, reach_table, flat_map())
    cfg = load_executor_config().model_copy(update={"touch_search_m": 0.01, "touch_force_n": 5000.0})
    phases = []
    rec = DigExecutor(sim, arm, cfg, ForceSensor(sim.model), sim.index.park).run(
        plan, on_phase=lambda name, _rec: phases.append(name))
    assert rec.outcome == "no contact" and phases == ["above entry", "touch-down", "no contact"]
    assert rec.warnings == ["no contact within 1 cm below the map"]
    assert list(rec.phase_starts) == ["above entry", "touch-down"]
    np.testing.assert_allclose(sim.observe().q, sim.index.park, atol=cfg.settle_tol_rad)  # parked


def test_moves_that_time_out_move_on_and_the_dig_completes_late(arm, reach_table):
    sim = Simulation(seed=0)
    plan = planned_dig(sim, arm, reach_table, flat_map())
    rec = run_dig(sim, arm, load_executor_config().model_copy(update={"move_timeout_s": 2.5}), plan)
    assert rec.outcome == "completed late"
    assert list(rec.phase_starts) == ["above entry", "touch-down", "dig", "lift out", "hold lifted", "over spoil",
                                      "dump", "park"]
    late = [w.split("'")[1] for w in rec.warnings if "did not settle within 2 s" in w]
    # the lift never settled, yet the waist swung: over the spoil side the arm found it there in time
    assert "lift out" in late and "over spoil" not in late


def stiff_soil_run(arm, reach_table, compliance: str):
    """Planned with the nominal sand; the world's sand is 6x stiffer at 10 cm (cohesion 9 kPa adds
    c d N_c w = 540 N to eq. 8's 102 N; 6.8 kPa stalled the wrist while the world added 30 % of the load as
    surcharge) and the wrist relief is 500 N m."""
    robot = load_robot_config()
    wrist = robot.joints.wrist_pitch.model_copy(update={"torque_limit_nm": 500.0})
    robot = robot.model_copy(update={"joints": robot.joints.model_copy(update={"wrist_pitch": wrist})})
    stiff = get_soil("testbed_sand").model_copy(update={"cohesion_pa": 9000.0})
    sim = Simulation(robot=robot, soil=stiff, seed=0)  # seed 2's weaker patches let this dig through
    plan = planned_dig(sim, arm, reach_table, flat_map())
    cfg = load_executor_config().model_copy(update={"compliance": compliance})
    return sim, plan, run_dig(sim, arm, cfg, plan)


@pytest.mark.parametrize("mode", ["stiffness", "impedance"])
def test_with_compliance_the_same_dig_completes(arm, reach_table, mode):
    """§5.4 / DiMaio: the path yields (rises) while a joint nears its limit, so the dig finishes."""
    sim, plan, rec = stiff_soil_run(arm, reach_table, mode)
    assert rec.outcome == "completed", (rec.outcome, rec.warnings)
    assert rec.stall is None
    rise = np.asarray(rec.compliance)
    assert 0.01 < rise.max() <= load_executor_config().compliance_max_m
    assert np.all(np.diff(rise) >= 0)  # the path only ever rises
    assert rec.bucket_volume_m3 > 0.005


def test_compliance_leaves_an_easy_dig_alone(arm, reach_table):
    sim = Simulation(seed=0)
    plan = planned_dig(sim, arm, reach_table, flat_map())
    cfg = load_executor_config().model_copy(update={"compliance": "stiffness"})
    rec = run_dig(sim, arm, cfg, plan)
    assert rec.completed and max(rec.compliance) == 0.0  # the wrist stays below 80 % of 1000 N m


def test_in_stiffer_soil_with_a_weak_wrist_the_dig_stalls_and_ends_cleanly(arm, reach_table):
    sim, plan, rec = stiff_soil_run(arm, reach_table, "off")
    assert rec.outcome == "stalled"
    assert rec.stall["joint"] == "wrist_pitch_joint" and abs(rec.stall["torque"]) >= 0.97 * 500
    assert rec.stall["tip"][0] < plan.poses[0, 0]  # somewhere along the dig
    assert abs(sim.truth.volumes.total - sim.soil.initial_volume) < 1e-12 * sim.soil.initial_volume
