"""Rowe's mass-excavation script, one for every machine (Rowe 1997 §4.2-4.3, §6.2): the clearance angle of
Fig. 3 against a hand derivation and MuJoCo, its two solvers against each other, the parameters' geometry on
the T3 and the 25 t, the listing on each machine and mirrored, the timing model, and the runner's coupled
trigger on both machines' servos."""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
import pytest

from excavsim.errors import GoalError
from excavsim.execution.conditions import always, joint_above, joint_below
from excavsim.execution.rowe_script.geometry import TruckSite, bucket_for_pitch, clearance_boom_angle
from excavsim.execution.rowe_script.listing import rowe_script
from excavsim.execution.rowe_script.params import compute_params
from excavsim.execution.rowe_script.runner import run_script
from excavsim.execution.rowe_script.timing import ProfileTiming, SwingProfile, TimingModel
from excavsim.execution.script import Command, Script, Step, SubScript
from excavsim.robot.excavators import EXCAVATOR_25T
from excavsim.robot.extract import arm_from_model
from excavsim.tasks.dump_trial import trial as truck
from excavsim.tasks.truck_loading import task as loading
from excavsim.tasks.truck_loading.config import load_truck_loading_file
from excavsim.tasks.truck_loading.world.truck import TruckSpec, TruckWorld
from excavsim.world.hydraulics import EXCAVATOR_JOINTS
from excavsim.world.simulation import Simulation

T3 = truck.SCRIPT_JOINTS
EX = loading.SCRIPT_JOINTS


@pytest.fixture(scope="module")
def world():
    return TruckWorld("excavator_25t", "dry_sand", seed=0)


@pytest.fixture(scope="module")
def arm25(world):
    return arm_from_model(world.model, joints=EXCAVATOR_JOINTS)


@pytest.fixture(scope="module")
def t3_cfg():
    return truck.load_truck_config()


@pytest.fixture(scope="module")
def t3_params(t3_cfg):
    return truck.nominal_params(t3_cfg, seed=0)


def _lowest(arm, boom, stick, bucket) -> float:
    """The bucket's lowest point [m, world z] at the given boom, stick and bucket angles."""
    return float(arm.bucket_points(arm.forward(np.array([boom, stick, bucket])))[:, 1].min())


# -- Fig. 3: the clearance angle ---------------------------------------------------------------------------
def test_clearance_angle_matches_the_hand_derivation(arm25):
    """Fig. 3 for the tip alone: z_f + A sin(theta + psi) = h + c with A e^(i psi) = l1 + l2 e^(i q2) +
    l3 e^(i (q2 + q3)), from the spec's link lengths and the truck's height."""
    a = EXCAVATOR_25T.arm
    h, c = TruckSpec().side_top_m, 0.3
    for q2, q3 in ((-1.7, -1.5), (-1.5, -1.8), (-1.9, -1.2)):
        v = a.boom_m + a.stick_m * np.exp(1j * q2) + a.bucket_m * np.exp(1j * (q2 + q3))
        hand = math.asin((h + c - a.boom_foot[1]) / abs(v)) - np.angle(v)
        got = clearance_boom_angle(arm25, q2, q3, h, c, outline=False)
        assert got == pytest.approx(hand, abs=1e-9)
        # the whole bucket: its lowest point is exactly at h + c, and lower just below the angle
        full = clearance_boom_angle(arm25, q2, q3, h, c)
        assert full >= got - 1e-12
        assert _lowest(arm25, full, q2, q3) == pytest.approx(h + c, abs=1e-9)
        assert _lowest(arm25, full - 0.01, q2, q3) < h + c


def test_clearance_angle_in_mujoco(world, arm25):
    """The model's own bucket tip, posed at the tip-only clearance angle, is at the truck's height plus the
    clearance."""
    h, c, q2, q3 = TruckSpec().side_top_m, 0.3, -1.7, -1.5
    boom = clearance_boom_angle(arm25, q2, q3, h, c, outline=False)
    d = mujoco.MjData(world.model)
    d.qpos[world._qpos] = [1.0, boom, q2, q3]
    mujoco.mj_kinematics(world.model, d)
    assert d.site_xpos[world.model.site("bucket_tip").id][2] == pytest.approx(h + c, abs=1e-6)


def test_the_two_solvers_agree_where_both_apply_and_bisection_goes_further(arm, arm25):
    """The closed form and the bisection on the lowest point give the same angle on both machines (the T3 at
    its configured side, the 25 t at its truck's); with the side at 0.5 m under the T3's 1.6 m shoulder part
    of its bucket never comes down that low, which the closed form refuses and the bisection does not."""
    cases = [(arm, 0.8, 0.08, ((-2.39, 0.39), (-2.49, 0.39), (-2.0, 0.8), (-2.4, 1.1))),
             (arm25, TruckSpec().side_top_m, 0.3, ((-1.7, -1.5), (-1.5, -1.8), (-1.9, -1.2), (-1.2, -0.5)))]
    for a, h, c, poses in cases:
        for q2, q3 in poses:
            closed = clearance_boom_angle(a, q2, q3, h, c)
            bisect = clearance_boom_angle(a, q2, q3, h, c, solve="bisect")
            assert bisect == pytest.approx(closed, abs=1e-12)
    with pytest.raises(GoalError, match="cannot clear"):
        clearance_boom_angle(arm, -2.49, 0.39, 0.45, 0.05)
    low = clearance_boom_angle(arm, -2.49, 0.39, 0.45, 0.05, solve="bisect")
    assert _lowest(arm, low, -2.49, 0.39) == pytest.approx(0.5, abs=1e-9)
    with pytest.raises(ValueError, match="allowed: 'closed', 'bisect'"):
        clearance_boom_angle(arm, -2.49, 0.39, 0.8, 0.08, solve="newton")


# -- §4.2: the parameters on each machine -------------------------------------------------------------------
def _t3_arm():
    return arm_from_model(Simulation(seed=0).model)


def test_the_t3_parameters_clear_the_side_and_time_the_trigger(t3_cfg, t3_params):
    """The T3's computed parameters (§4.2, the dump at the site's height): carried and at the dump the bucket
    is above the truck's side with its clearance, the bucket is curled past the dig's end, and the
    boom trigger is the clearance angle less the boom's rise while the swing crosses to the truck's edge
    (the timing model by hand: full speed, 0.8 of the time)."""
    p, site, a = t3_params, t3_cfg.site, _t3_arm()
    lim = site.side_z + site.clearance
    assert _lowest(a, p.boom_carry, p.stick_carry, p.bucket_carry) >= lim - 1e-9
    assert _lowest(a, p.boom_dump, p.stick_dump, p.bucket_carry) >= lim - 1e-9
    assert p.boom_carry >= p.boom_clear >= p.boom_dig and p.boom_dump >= p.boom_clear_dump
    # the bucket curls 10 deg past the dig's end, and further as the boom rises (holding the pitch)
    assert p.bucket_carry <= p.bucket_dig - math.radians(10.0) - 0.5 * (p.boom_carry - p.boom_dig)
    sim = Simulation(seed=0)
    speed = dict(zip(truck.constants.JOINTS, sim.rate_limit))
    edge = site.theta_d - site.half_width / site.r_d
    by_hand = p.boom_clear - 0.8 * speed[T3.boom] * abs(edge - p.swing_dig) / speed[T3.swing]
    assert p.boom_trigger == pytest.approx(min(max(by_hand, p.boom_dig + 0.01), p.boom_clear), abs=1e-9)
    assert p.swing_back == pytest.approx(p.swing_dig + 0.75 * (p.swing_dump - p.swing_dig))


def test_the_25t_parameters_pour_over_the_aim_with_the_opening_arc_clear(arm25):
    """The 25 t's computed parameters (the lowest dump clear of the side): the tip at the pour's pitch is over
    the aim within the stick search's resolution, the whole arc the bucket sweeps while it opens stays above
    the side with its clearance, the carry clears it too, and the swing's time comes from its profile."""
    f = load_truck_loading_file()
    t = TruckSpec()
    site = TruckSite(math.hypot(t.x_m, t.y_m), math.atan2(t.y_m, t.x_m), t.side_top_m, 0.5 * t.length_m,
                     f.script.clearance_m)
    q_dig, ok = arm25.inverse(np.array([6.0, 0.4, math.radians(f.autodig.capture_deg)]))
    assert ok
    profile = SwingProfile(0.15, 1.0)
    timing = ProfileTiming(profile, boom_speed=0.17)
    aim = (site.r_d, site.theta_d)
    p = compute_params(arm25, site, loading.script_rules(f), timing, q_dig, 0.3, dump_at=aim, return_pose=q_dig)
    lim = site.side_z + site.clearance
    pour = bucket_for_pitch(arm25, p.boom_dump, p.stick_dump, math.radians(f.script.pour_pitch_deg))
    assert float(arm25.forward(np.array([p.boom_dump, p.stick_dump, pour]))[0]) == pytest.approx(aim[0], abs=0.25)
    for b in np.linspace(p.bucket_carry, p.bucket_open, 12):
        assert _lowest(arm25, p.boom_dump, p.stick_dump, b) >= lim - 1e-9
    assert _lowest(arm25, p.boom_carry, p.stick_carry, p.bucket_carry) >= lim - 1e-9
    travel = abs(site.theta_d - site.half_width / site.r_d - 0.3)
    # a triangle at this travel (below v^2 / a = 6.7 rad: accelerate half of it, brake the other half)
    assert profile.time_to_cover(travel) == pytest.approx(2.0 * math.sqrt(travel / 0.15))
    assert profile.time_to_cover(8.0) == pytest.approx(8.0 / 1.0 + 1.0 / 0.15)  # a trapezoid beyond it
    by_hand = p.boom_clear - f.script.safety * 0.17 * profile.time_to_cover(travel)
    assert p.boom_trigger == pytest.approx(min(max(by_hand, q_dig[0] + 0.01), p.boom_clear), abs=1e-12)
    assert p.open_lead == pytest.approx(math.radians(6.0)) and p.dumped_fraction is None


def test_the_timing_model():
    tm = TimingModel({"j": 0.5}, gain=8.0, latency=0.1)
    assert tm.travel_time("j", 1.0) == pytest.approx(2.1)
    # the remaining distance some time before arrival inverts the time to go
    for d in (0.02, 0.5, 1.5):
        t = tm.time_to("j", d, 0.01) - tm.latency
        assert tm.remaining("j", t, 0.01) == pytest.approx(d, rel=1e-9)


# -- §6.2's listing -----------------------------------------------------------------------------------------
def _steps(script):
    return {sub.joints: [st.name for st in sub.steps] for sub in script.subscripts}


def test_the_listing_on_each_machine(t3_params):
    """The T3 runs §6.2's listing whole (the dump waits for the stick, boom and stick continue once the bucket
    is 60 % open, the wrist held level); parameters without those shares (the 25 t's) leave them out."""
    t3 = rowe_script(t3_params, T3)
    assert _steps(t3) == {
        (T3.swing,): ["swing wait", "swing to truck", "swing to dig face", "stop to dig"],
        (T3.boom,): ["raise boom", "boom dump", "boom continue", "lower boom"],
        (T3.stick,): ["stick wait", "stick out", "stick continue", "stick to dig"],
        (T3.bucket,): ["capture", "open bucket", "bucket to dig"],
        T3.level: ["level"]}
    assert t3.subscripts[-1].steps[0].command.targets == (0.0, 0.0)
    opening = t3.subscripts[3].steps[1].when
    assert opening.kind == "all" and opening.children[1].joint == T3.stick
    p = dataclasses.replace(t3_params, stick_open_fraction=None, dumped_fraction=None, stick_after=None)
    ex = rowe_script(p, EX)
    assert _steps(ex) == {(EX.swing,): ["swing wait", "swing to truck", "swing to dig face", "stop to dig"],
                          (EX.boom,): ["raise boom", "boom dump", "lower boom"],
                          (EX.stick,): ["stick wait", "stick out", "stick to dig"],
                          (EX.bucket,): ["capture", "open bucket", "bucket to dig"]}
    assert ex.subscripts[3].steps[1].when == joint_above(EX.swing, p.swing_dump - p.open_lead)
    assert "boom_clear" in p.degrees() and "dumped_fraction" not in p.degrees()


def test_a_truck_on_the_other_side_mirrors_the_swing_conditions(t3_params):
    """With the truck at a smaller swing angle than the dig, every comparison on the swing turns round."""
    p = dataclasses.replace(t3_params, swing_dig=0.5, swing_dump=-0.6, swing_back=-0.3, open_lead=0.1, stop_tol=0.03)
    s = rowe_script(p, T3)
    swing, boom, stick = (sub.steps for sub in s.subscripts[:3])
    assert swing[3].when == joint_above(T3.swing, 0.5 - 0.03)
    assert boom[1].when.children[0] == joint_below(T3.swing, -0.6 + 0.1)
    assert stick[1].when == joint_below(T3.swing, 0.5 + p.stick_fraction * (-0.6 - 0.5))
    assert boom[3].when.children[1] == joint_above(T3.swing, -0.3)
    assert swing[1].when == joint_above(T3.boom, p.boom_trigger)  # the boom rises either way
    x = p.values(truck.TUNED)
    assert p.with_values(truck.TUNED, x + 0.01).values(truck.TUNED) == pytest.approx(x + 0.01)


# -- the runner on both machines ----------------------------------------------------------------------------
def _coupled(q0, joints, trigger: float, swing_to: float, timeout_s: float) -> Script:
    """The swing waits until the boom passes ``trigger`` (Rowe & Stentz's coupling), then swings."""
    return Script("coupled", (
        SubScript((joints.swing,), (Step("wait", always(), Command((q0[0],))),
                                    Step("swing", joint_above(joints.boom, trigger), Command((swing_to,))),
                                    Step("there", (joint_above if swing_to > q0[0] else joint_below)(
                                        joints.swing, swing_to - 0.02 * np.sign(swing_to - q0[0])),
                                        Command((swing_to,)), ends=always()))),
        SubScript((joints.boom,), (Step("raise", always(), Command((q0[1] + math.radians(15.0),))),)),
    ), timeout_s=timeout_s)


def test_the_swing_starts_when_the_boom_passes_its_angle_on_the_t3():
    sim = Simulation(seed=0)
    for _ in range(10):
        sim.track(sim.joint_angles())
    t0, q0 = sim.time, sim.joint_angles()
    trigger = q0[1] + math.radians(5.0)
    seen = []
    sim.step_hooks.append(lambda s: seen.append((s.time, s.joint_angles()[1])))
    run = run_script(sim, _coupled(q0, T3, trigger, q0[0] + 0.3, 5.0), T3)
    assert run.outcome == "end" and run.start == t0 > 0.0  # the simulation's clock
    t_swing = run.phase_starts()["swing"] + run.start
    before = [b for t, b in seen if t < t_swing - 1e-9]
    assert before and max(before) <= trigger  # the swing waited while the boom was below its angle
    # it fired on the first tick after the boom passed (within a tick: the engine reads the last observation)
    first_above = min(t for t, b in seen if b > trigger)
    assert t_swing == pytest.approx(first_above, abs=1.5 * sim.control_dt)
    assert run.angle_at("swing", T3.boom) > trigger and math.isnan(run.angle_at("never", T3.boom))


def test_the_25t_swings_along_its_profile_on_the_tick_clock():
    """On the 25 t the swing's command goes through its profile: it starts once the boom passed its angle and
    never turns faster than the profile's top speed (a step command turns it at 0.67 rad/s here); the tick
    clock starts at 0 and moves in control periods."""
    w = TruckWorld("excavator_25t", "dry_sand", seed=0)
    q0 = w.joint_angles()
    trigger = q0[1] + math.radians(4.0)
    profile = SwingProfile(0.15, 0.4)
    swing = []
    w.step_hooks.append(lambda s: swing.append(s.joint_angles()[0]))
    run = run_script(w, _coupled(q0, EX, trigger, q0[0] + 0.6, 20.0), EX, profile=profile, tick_clock=True)
    assert run.outcome == "end" and run.start == 0.0
    assert run.angle_at("swing", EX.boom) > trigger
    ticks = run.duration / w.control_dt
    assert ticks == pytest.approx(round(ticks), abs=1e-6)
    rate = np.abs(np.diff(swing)) / w.control_dt
    assert rate.max() <= profile.speed * 1.1
