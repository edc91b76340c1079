"""DiMaio's playback on the TB035 (DiMaio 1998 §4.2, Table 4.1): the cylinder-pressure force, the scripted
demonstration and its playback with Table 4.1's impedance, teleoperation of the four joints, the command."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from excavsim.apps.playback.adapter import W, soils
from excavsim.apps.playback.cylinder_arm import TABLE_4_1
from excavsim.apps.playback.driver import controllers, play, record_demonstration
from excavsim.apps.playback.machines import adapter_for
from excavsim.apps.playback.teleop import teleoperate
from excavsim.cli import main
from excavsim.config import get_soil
from excavsim.execution.demonstration import Demonstration, load_demonstration
from excavsim.execution.playback import FixedImpedance, VariableImpedance
from excavsim.execution.teleop import FINISH, SWING_KEYS, TeleopOptions, apply_swing_key
from excavsim.readouts import element_id


def test_the_cylinder_forces_give_the_force_applied_to_the_bucket():
    """A known force on the bucket, the arm held still in the air: the static balance of the cylinder forces
    reads it within 50 N (the pin's F/T would read the link's load too)."""
    rig = adapter_for("tb035").rig(get_soil("testbed_sand"), 0)
    rig.servos.noise_n = 0.0
    target = rig.joints_of(np.array([3.0, 0.6, 0.3]))
    rig.move_to(target)
    m, d, w = rig.world.model, rig.world.data, rig.world
    bucket = element_id(m, "body", "bucket")
    for force in ([2000.0, 0.0, 0.0], [0.0, 0.0, -3000.0], [-1500.0, 0.0, 1000.0]):
        for _ in range(100):
            d.ctrl[w.drive.act] = w.drive.rates(target, w.drive.setpoints(d))
            d.xfrc_applied[bucket] = np.r_[force, 0.0, 0.0, 0.0]
            mujoco.mj_step(m, d, w.substeps)
        _, f = rig.sample(0.0)
        assert f == pytest.approx([force[0], force[2]], abs=50.0)


def test_table_4_1_fixes_the_damping_of_both_laws():
    imp = TABLE_4_1
    fixed = FixedImpedance("p", imp.mass_kg, imp.k_high_n_m, damping=imp.damping_n_s_m)
    fixed.reset(2, 0.02)
    k, b = fixed.gains(np.zeros(2), np.zeros(2))
    assert k.tolist() == [1e5, 1e5] and b.tolist() == [5000.0, 5000.0]
    var = VariableImpedance("v", imp.mass_kg, imp.k_low_n_m, imp.k_high_n_m, 2000.0, damping=imp.damping_n_s_m)
    var.reset(2, 0.02)
    k, b = var.gains(np.array([5000.0, 0.0]), np.array([0.01, 0.5]))  # hard contact on x, free motion on z
    assert b.tolist() == [5000.0, 5000.0] and imp.k_low_n_m <= k[0] < k[1] <= imp.k_high_n_m
    critical = FixedImpedance("c", 100.0, 1e5)
    critical.reset(2, 0.02)
    assert critical.gains(np.zeros(2), np.zeros(2))[1][0] == pytest.approx(6324.6, abs=0.1)


@pytest.fixture(scope="module")
def tb035_demo():
    return record_demonstration(0, machine="tb035").with_approach(0.10, 1.0)


def test_the_tb035_demonstration_is_a_cut_with_force(tb035_demo):
    d = tb035_demo
    assert d.dt == pytest.approx(0.02)
    assert d.pose[:, 1].min() < -0.15  # down to the cut's depth (0.2 m, less the drive's lag)
    assert d.pose[0, 0] - d.pose[-1, 0] > 0.7  # dragged towards the machine (1 m, less the lag)
    peak = np.linalg.norm(d.force, axis=1).max()
    assert 1000.0 < peak < 20000.0
    assert np.abs(d.force[:40]).max() < 500.0  # the approach is in the air


def test_playback_in_the_same_soil_tracks_and_in_a_stiffer_one_the_variable_impedance_wins(tb035_demo):
    chapter = soils()
    pos, var = controllers(TABLE_4_1)[0], controllers(TABLE_4_1)[2]
    same, moved = play(tb035_demo, chapter["same"], "same", pos, machine="tb035")
    e = same.errors(W)
    assert same.outcome == "completed" and moved > 0.03
    assert e["pos_rms_m"] < 0.08  # the drive's lag at 0.2 m/s is 5 cm
    assert e["force_rms_n"] < 0.3 * e["demo_force_peak_n"]
    stiff = next(k for k in chapter if k.startswith("stiffer"))
    e_pos = play(tb035_demo, chapter[stiff], stiff, pos, machine="tb035")[0].errors(W)
    e_var = play(tb035_demo, chapter[stiff], stiff, var, machine="tb035")[0].errors(W)
    assert e_var["weighted_error"] < 0.6 * e_pos["weighted_error"]
    assert e_var["force_rms_n"] < e_pos["force_rms_n"]


def test_swing_keys_turn_the_cab_and_plane_keys_do_not():
    opts = TeleopOptions()
    assert apply_swing_key(0.1, "z", opts) == pytest.approx(0.1 + opts.swing_step_rad)
    assert apply_swing_key(0.1, "c", opts) == pytest.approx(0.1 - opts.swing_step_rad)
    assert apply_swing_key(0.1, "a", opts) is None
    assert set(SWING_KEYS) == {"z", "c"}


def test_a_scripted_teleop_session_drives_all_four_joints_of_the_tb035():
    """Swing left, reach out, go up, curl: the swing, boom, stick and bucket encoders all move."""
    seen = []
    keys = "z" * 10 + "d" * 6 + "w" * 8 + "q" * 6 + FINISH + "zzz"
    demo = teleoperate(keys, machine="tb035", on_key=lambda k, p, f: seen.append((k, p.copy())))
    assert [k for k, _ in seen] == list(keys.split(FINISH)[0])
    assert len(demo.times) == len(seen) * TeleopOptions().ticks_per_key
    # the swing moved by 10 steps (its median is the demonstration's plane); the tip moved out, up and curled
    assert demo.waist > 3 * TeleopOptions().swing_step_rad
    first, last = demo.pose[0], demo.pose[-1]
    assert last[0] - first[0] > 0.08 and last[1] - first[1] > 0.1 and last[2] - first[2] > 0.2
    # joint-level: every joint's angle changed (inverse kinematics of the measured tip)
    rig = adapter_for("tb035").rig(get_soil("testbed_sand"), 0)
    q0, q1 = rig.arm.inverse(first)[0], rig.arm.inverse(last)[0]
    assert np.all(np.abs(q1 - q0) > 0.02)


def test_the_playback_command_on_the_tb035(tmp_path):
    out = tmp_path / "tele"
    assert main(["playback", "--machine", "tb035", "--teleop", "--keys", "zzdds" + FINISH, "--out", str(out)]) == 0
    demo = load_demonstration(out / "teleop_demonstration.json")
    assert demo.dt == pytest.approx(0.02) and len(demo.times) == 5 * TeleopOptions().ticks_per_key
    t3_rate = Demonstration(np.arange(3) * 0.01, np.zeros((3, 3)), np.zeros((3, 2)), 0.01, 0.0, "T3", "sand")
    assert main(["playback", "--machine", "tb035", "--demo", str(t3_rate.save(tmp_path / "t3.json"))]) == 2
    assert main(["playback", "--machine", "tb035", "--teleop", "--keys", "zzk"]) == 2
    assert main(["playback", "--machine", "tb035", "--from-rrd", "x.rrd"]) == 2  # no wrist F/T on it
    # --live streams the session as on the T3: nothing listens at this address, so it is refused before the world
    assert main(["playback", "--machine", "tb035", "--teleop", "--keys", "zz", "--live", "127.0.0.1:9"]) == 2
    assert main(["playback", "--machine", "no_such_machine"]) == 2
