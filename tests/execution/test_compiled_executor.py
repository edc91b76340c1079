"""The executor's compiled per-step path against the reference implementations it replaces (issue 17).

Each compiled piece must give the reference's numbers bit for bit: the F/T compensation, the servo
law, the path cursor's interpolation, the tip pose, the script engine's decisions (the engine's own
tests, random scripts on random senses), and whole digs run by ``DigExecutor`` in its compiled and
its reference mode (a completed dig, a stall, moves that time out, a touch-down without contact).
"""

from __future__ import annotations

import inspect
import math

import numpy as np
import pytest

from tests.execution import test_execution as te
from excavsim import constants
from excavsim.config import load_executor_config
from excavsim.errors import ExcavsimError
from excavsim.execution import conditions as c
from excavsim.execution.dig import DigExecutor
from excavsim.execution.paths import interp_pose, point_at, segment_lengths
from excavsim.execution.script import Abort, Command, CompiledEngine, Script, ScriptEngine, Step, SubScript, Watch
from excavsim.handoff.observation import Observation
from excavsim.rig.core import bucket_witness
from excavsim.robot.fast import arm_params, forward_pose
from excavsim.robot.servo import setpoint_rates, setpoint_rates_reference
from excavsim.sensing.ft import (TIP_ORDERS, ForceSensor, compiled_matches_numpy, compiled_order, environment_wrench,
                                 wrench_kernel)
from excavsim.world.simulation import Simulation

JOINTS = list(constants.JOINTS)


def test_the_compiled_ft_reading_equals_the_numpy_reading(mj_model, rng):
    """Random joint angles and wrist readings: reading_into gives reading's four vectors to the bit."""
    sensor = ForceSensor(mj_model)
    assert sensor._fast == compiled_matches_numpy()
    out = np.empty((4, 3))
    for _ in range(3000):
        obs = Observation(float(rng.uniform(0, 100)), rng.uniform(-1.5, 1.5, 6), np.zeros(6), np.zeros(6),
                          rng.normal(size=3) * rng.choice([1.0, 500.0, 5e4]), rng.normal(size=3) * 300.0)
        r = sensor.reading(obs)
        sensor.reading_into(obs, out)
        for ref, got in zip((r.force_tip, r.torque_tip, r.force_world, r.torque_world), out):
            assert np.array_equal(ref, got)


def test_the_wrench_kernel_equals_environment_wrench_on_random_frames(rng):
    """The compensation itself, on random (not only rotation) matrices and positions: where the
    machine's BLAS rounds as the kernel does in the order found at first use, equal to the bit."""
    order = compiled_order()
    assert -1 <= order < len(TIP_ORDERS) and compiled_matches_numpy() == (order >= 0)
    out = np.empty((4, 3))
    equal = True
    for _ in range(3000):
        xmat, xpos, com = rng.normal(size=(2, 9)), rng.normal(size=(2, 3)), rng.normal(size=(1, 3))
        f, t, w = rng.normal(size=3) * 400, rng.normal(size=3) * 100, rng.normal(size=3) * 300
        ref = environment_wrench(f, t, sensor_rot=xmat[0].reshape(3, 3), sensor_pos=xpos[0],
                                 tip_rot=xmat[1].reshape(3, 3), tip_pos=xpos[1], com=com[0], weight=w)
        assert wrench_kernel(f, t, xmat, xpos, com, 0, 1, 0, w, out, max(order, 0))
        equal &= all(np.array_equal(r, o) for r, o in zip(ref, out))
    assert equal == (order >= 0)
    assert not wrench_kernel(np.array([np.nan, 0, 0]), t, xmat, xpos, com, 0, 1, 0, w, out)


def test_the_compiled_ft_reading_refuses_what_the_reference_refuses(mj_model):
    sensor = ForceSensor(mj_model)
    good = Observation(0.0, np.zeros(6), np.zeros(6), np.zeros(6), np.zeros(3), np.zeros(3))
    out = np.empty((4, 3))
    bad = [good.__class__(**{**good.__dict__, "q": np.r_[0.0, np.nan, 0, 0, 0, 0]}),
           good.__class__(**{**good.__dict__, "ft_force": np.array([0.0, np.inf, 0.0])}),
           good.__class__(**{**good.__dict__, "ft_torque": np.zeros(4)}),
           good.__class__(**{**good.__dict__, "time": math.nan}), object()]
    for obs in bad:
        with pytest.raises(ExcavsimError) as ref:
            sensor.reading(obs)
        with pytest.raises(ExcavsimError) as got:
            sensor.reading_into(obs, out)
        assert str(got.value) == str(ref.value)


def test_the_compiled_servo_law_equals_numpy_clip(rng):
    limit = rng.uniform(0.1, 1.0, 6)
    for k in range(5000):
        target, q = rng.normal(size=6) * rng.choice([0.01, 1.0, 10.0]), rng.normal(size=6)
        if k % 50 == 0:
            target[k % 6] = np.nan
        got = setpoint_rates(target, q, gain_per_s=4.0, rate_limit=limit)
        ref = setpoint_rates_reference(target, q, gain_per_s=4.0, rate_limit=limit)
        assert np.array_equal(got, ref, equal_nan=True) and np.array_equal(np.signbit(got), np.signbit(ref))
    batch = rng.normal(size=(4, 6))  # other shapes go through numpy
    assert np.array_equal(setpoint_rates(batch, 0 * batch, gain_per_s=4.0, rate_limit=limit),
                          setpoint_rates_reference(batch, 0 * batch, gain_per_s=4.0, rate_limit=limit))


def test_the_compiled_path_cursor_interpolates_as_np_interp(rng):
    """Random polylines, with repeated vertices, at random lengths, at every vertex and at the ends."""
    out = np.empty(3)
    for k in range(3000):
        n = int(rng.integers(1, 9))
        path = rng.normal(size=(n, 3))
        if n > 2 and k % 3 == 0:
            path[1] = path[0]
        if n > 3 and k % 5 == 0:
            path[3] = path[2]
        cum = np.concatenate([[0.0], np.cumsum(segment_lengths(path, 0.5))])
        for s in [*rng.uniform(0, cum[-1], 10), *cum, 0.0, np.nextafter(cum[-1], 0.0)]:
            interp_pose(path, s, cum, out)
            assert np.array_equal(out, point_at(path, s, cum))


def test_the_compiled_tip_pose_equals_the_planar_arm(arm, rng):
    q = rng.uniform(-3.0, 3.0, (20000, 3))
    q[:3] = 0.0
    p = arm_params(arm)
    assert np.array_equal(np.array([forward_pose(p, *x) for x in q]), arm.forward(q))


# -- the script engine ------------------------------------------------------------------------------

def test_the_engine_tests_pass_on_the_compiled_engine(monkeypatch):
    """tests/execution/test_execution.py's engine tests, run again with CompiledEngine in place of ScriptEngine."""
    monkeypatch.setattr(te, "ScriptEngine", CompiledEngine)
    ran = []
    for name, fn in vars(te).items():
        if name.startswith("test_") and "ScriptEngine" in inspect.getsource(fn) \
                and not inspect.signature(fn).parameters:
            fn()
            ran.append(name)
    assert len(ran) >= 5, ran


def random_cond(rng, depth: int, tag: str) -> c.Cond:
    """A random condition over the shoulder and waist, the force, time in the step and a few events."""
    leaves = [lambda: c.always(), lambda: c.joint_above("shoulder_joint", rng.uniform(-0.5, 0.5)),
              lambda: c.joint_below("waist_joint", rng.uniform(-0.5, 0.5)), lambda: c.after(rng.uniform(0, 0.5)),
              lambda: c.past(rng.uniform(0, 0.5)), lambda: c.reached("shoulder_joint", rng.uniform(0.05, 0.5)),
              lambda: c.settled(("shoulder_joint", "waist_joint"), rng.uniform(0.05, 0.5)),
              lambda: c.force_above(rng.uniform(0, 150)), lambda: c.force_below(rng.uniform(0, 150)),
              lambda: c.event(str(rng.choice(["ping", "pong", "started:a1", f"path_end:{tag}"]))),
              lambda: c.timed_out()]
    r = rng.uniform()
    if depth <= 0 or r < 0.4:
        return leaves[int(rng.integers(len(leaves)))]()
    if r < 0.55:
        return c.held(random_cond(rng, depth - 1, tag), ticks=int(rng.integers(1, 4)))
    if r < 0.7:
        return c.held(random_cond(rng, depth - 1, tag), seconds=float(rng.uniform(0, 0.3)))
    kids = [random_cond(rng, depth - 1, tag) for _ in range(int(rng.integers(0, 4)))]
    return c.all_of(*kids) if r < 0.85 else c.any_of(*kids)


def random_script(rng) -> Script:
    subs = []
    for name, joints in (("a", ("shoulder_joint",)), ("b", ("waist_joint",))):
        steps = []
        for k in range(int(rng.integers(2, 5))):
            path = k % 2 == 1 and name == "a"
            cmd = Command(path="p" + str(k), speed=0.1, tol=0.2) if path else Command((float(rng.uniform(-1, 1)),))
            shared = random_cond(rng, 2, "p1")
            steps.append(Step(f"{name}{k}", random_cond(rng, 3, "p1") if k else c.always(), cmd,
                              float(rng.uniform(0.2, 1.0)) if rng.uniform() < 0.5 else None,
                              watches=(Watch("ping", c.all_of(shared, random_cond(rng, 2, "p1"))),
                                       Watch("pong", c.any_of(shared, shared))) if rng.uniform() < 0.6 else (),
                              abort=Abort("gave up", random_cond(rng, 2, "p1")) if rng.uniform() < 0.3 else None,
                              ends=random_cond(rng, 2, "p1") if rng.uniform() < 0.3 else None))
        subs.append(SubScript(joints, tuple(steps)))
    return Script("random", tuple(subs), timeout_s=float(rng.uniform(1.0, 3.0)) if rng.uniform() < 0.5 else None)


def test_the_compiled_engine_decides_as_the_reference_on_random_scripts(rng):
    """Random scripts (nested, held, shared and timed conditions, watches, aborts, endings, paths) on
    random senses: every tick the same steps, events, targets, timeouts and stop."""
    for _ in range(150):
        script = random_script(rng)
        ref, got = ScriptEngine(script), CompiledEngine(script, JOINTS)
        q = np.zeros(6)
        for k in range(60):
            t = 0.05 * k
            q[[0, 1]] += rng.normal(size=2) * 0.1
            ev = frozenset(rng.choice(["ping", "pong", "other"], size=int(rng.integers(0, 2))))
            s = te.sense(t, q.copy(), float(rng.uniform(0, 200)), ev)
            cr, cg = ref.tick(s), got.tick(s)
            assert cr == cg and ref.stop == got.stop
            if ref.stop is None:
                for i, cmd in enumerate(cr):
                    if cmd.path:
                        tgt, end = [float(q[1] + rng.normal() * 0.1)], bool(rng.uniform() < 0.3)
                        ref.report(i, tgt, at_end=end)
                        got.report(i, tgt, at_end=end)
                ref.end_tick(s)
                got.end_tick(s)
            assert ref.transitions == got.transitions and ref.timeouts == got.timeouts
            assert ref.events == got.events and ref.targets == got.targets and ref.stop == got.stop
            assert ref.index == got.index and ref.entered == got.entered and ref.finished == got.finished
            if ref.stop is not None:
                break


# -- whole digs, compiled against reference ---------------------------------------------------------

def dig_both_ways(make_sim, arm, cfg, plan):
    """The same dig run by the compiled and the reference executor on two identical worlds."""
    out = []
    for reference in (False, True):
        sim = make_sim()
        phases = []

        def on_phase(name, rec, sim=sim, phases=phases):
            phases.append(name)
            bucket_witness(sim)(name, rec)

        ex = DigExecutor(sim, arm, cfg, ForceSensor(sim.model), sim.index.park, reference=reference)
        rec = ex.run(plan, on_phase=on_phase)
        state = np.concatenate([sim.data.qpos, sim.data.qvel, sim.data.act, sim.soil.grid.heights.ravel()])
        out.append((rec, phases, state, sim.steps))
    return out


def assert_same_dig(a, b):
    (ra, pa, sa, na), (rb, pb, sb, nb) = a, b
    assert na == nb and pa == pb and np.array_equal(sa, sb)
    for field in ("outcome", "phase_times", "phase_starts", "warnings", "touch_offset_m", "planned_volume_m3",
                  "script_text", "times", "compliance"):
        assert getattr(ra, field) == getattr(rb, field), field
    for field in ("touch_expected_z", "touch_found_z", "lifted_load_n", "bucket_volume_m3"):
        x, y = getattr(ra, field), getattr(rb, field)
        assert x == y or (math.isnan(x) and math.isnan(y)), field
    assert (ra.planned_path is None and rb.planned_path is None) or np.array_equal(ra.planned_path, rb.planned_path)
    assert len(ra.ft) == len(rb.ft) and all(t1 == t2 and np.array_equal(f1, f2)
                                            for (t1, f1), (t2, f2) in zip(ra.ft, rb.ft))
    assert np.array_equal(np.asarray(ra.torques), np.asarray(rb.torques))
    assert np.array_equal(np.asarray(ra.executed_path), np.asarray(rb.executed_path))
    assert (ra.stall is None) == (rb.stall is None)
    if ra.stall is not None:
        assert ra.stall["joint"] == rb.stall["joint"] and ra.stall["time"] == rb.stall["time"]
        assert ra.stall["torque"] == rb.stall["torque"] and np.array_equal(ra.stall["tip"], rb.stall["tip"])


@pytest.fixture(scope="module")
def flat_plan(arm, reach_table):
    return te.planned_dig(Simulation(seed=0), arm, reach_table, te.flat_map())


def test_a_completed_dig_is_the_same_compiled_and_in_python(arm, flat_plan):
    a, b = dig_both_ways(lambda: Simulation(seed=0), arm, load_executor_config(), flat_plan)
    assert a[0].outcome == "completed" and len(a[0].executed_path) > 100
    assert_same_dig(a, b)


def test_moves_that_time_out_and_a_missed_contact_are_the_same_compiled_and_in_python(arm, flat_plan):
    late = load_executor_config().model_copy(update={"move_timeout_s": 2.5})
    a, b = dig_both_ways(lambda: Simulation(seed=0), arm, late, flat_plan)
    assert a[0].outcome == "completed late"
    assert_same_dig(a, b)
    missed = load_executor_config().model_copy(update={"touch_search_m": 0.01, "touch_force_n": 5000.0})
    a, b = dig_both_ways(lambda: Simulation(seed=2), arm, missed, flat_plan)
    assert a[0].outcome == "no contact"
    assert_same_dig(a, b)


def test_a_stall_is_the_same_compiled_and_in_python(arm, flat_plan):
    """Stiff sand, a 500 N m wrist: the dig stalls and backs out along the path it took."""
    from excavsim.config import get_soil, load_robot_config

    robot = load_robot_config()
    wrist = robot.joints.wrist_pitch.model_copy(update={"torque_limit_nm": 500.0})
    robot = robot.model_copy(update={"joints": robot.joints.model_copy(update={"wrist_pitch": wrist})})
    stiff = get_soil("testbed_sand").model_copy(update={"cohesion_pa": 9000.0})
    a, b = dig_both_ways(lambda: Simulation(robot=robot, soil=stiff, seed=0), arm, load_executor_config(), flat_plan)
    assert a[0].outcome == "stalled"
    assert_same_dig(a, b)
