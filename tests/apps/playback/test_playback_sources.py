"""Where demonstrations come from besides an executor record: teleoperation from a key sequence and
a dig read back from a Rerun recording (DiMaio 1998 ch. 6; excavsim playback --teleop / --from-rrd)."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest

from excavsim.cli import main
from excavsim.errors import ExcavsimError
from excavsim.execution.demonstration import Demonstration, demonstration_from_record, load_demonstration
from excavsim.execution.teleop import FINISH, TeleopOptions, apply_key


def test_each_key_moves_the_commanded_tip_one_step_in_the_arm_plane():
    opts = TeleopOptions(step_m=0.02, pitch_step_rad=math.radians(3.0))
    p = np.array([2.0, 0.5, 0.8])
    assert apply_key(p, "a", opts) == pytest.approx([1.98, 0.5, 0.8])
    assert apply_key(p, "d", opts) == pytest.approx([2.02, 0.5, 0.8])
    assert apply_key(p, "w", opts) == pytest.approx([2.0, 0.52, 0.8])
    assert apply_key(p, "s", opts) == pytest.approx([2.0, 0.48, 0.8])
    assert apply_key(p, "q", opts)[2] == pytest.approx(0.8 + math.radians(3.0))
    assert apply_key(p, ".", opts) == pytest.approx(p)
    assert apply_key(p, FINISH, opts) is None
    with pytest.raises(ExcavsimError, match="allowed"):
        apply_key(p, "z", opts)
    with pytest.raises(ExcavsimError):
        TeleopOptions(step_m=0.0)


def test_a_teleoperated_key_sequence_writes_a_demonstration_that_validates(tmp_path):
    from excavsim.apps.playback.teleop import teleoperate
    keys = "s" * 12 + "a" * 15 + "w" * 8 + FINISH + "ssss"  # down into the soil, drag toward the base, up; x ends
    seen = []
    demo = teleoperate(keys, on_key=lambda k, p, f: seen.append(k))
    assert seen == list(keys.split(FINISH)[0])
    assert len(demo.times) == len(seen) * TeleopOptions().ticks_per_key
    back = load_demonstration(demo.save(tmp_path / "teleop.json"))
    assert np.array_equal(back.pose, demo.pose) and back.dt == demo.dt and "teleoperation" in back.source
    # the tip went down 12 steps, toward the base 15 and up 8 (within the servo's lag and the soil's push)
    assert demo.pose[0, 1] - demo.pose[:, 1].min() == pytest.approx(0.24, abs=0.05)
    assert demo.pose[0, 0] - demo.pose[-1, 0] == pytest.approx(0.30, abs=0.06)
    assert np.linalg.norm(demo.force, axis=1).max() > 100.0  # the drag was in the soil and the F/T felt it
    # the file plays back (what `excavsim playback --demo FILE` runs, here without the figures)
    from excavsim.apps.playback.driver import run_playback
    lines = []
    table = run_playback(None, demo=load_demonstration(tmp_path / "teleop.json"), sweep=False, progress=lines.append)
    assert len(table) == 12 and {s for s, _ in table} == {"same", "stiffer x3", "softer x0.3"}
    assert "demonstration given" in lines[0] and "teleoperation" in lines[0]


def test_conflicting_or_bad_playback_arguments_exit_2_naming_the_fix(tmp_path, capsys):
    assert main(["playback", "--teleop", "--from-rrd", "x.rrd"]) == 2
    assert "cannot be combined" in capsys.readouterr().err
    assert main(["playback", "--dig", "2"]) == 2
    assert "--from-rrd" in capsys.readouterr().err
    (tmp_path / "bad.json").write_text('{"format": "excavsim-demonstration", "version": 1}')
    assert main(["playback", "--demo", str(tmp_path / "bad.json")]) == 2
    assert "missing keys" in capsys.readouterr().err
    assert main(["playback", "--from-rrd", str(tmp_path / "none.rrd")]) == 2
    assert "no recording" in capsys.readouterr().err
    far = Demonstration(np.arange(3) * 0.01, np.tile([9.0, 9.0, 0.0], (3, 1)), np.zeros((3, 2)), 0.01, 0.0)
    assert main(["playback", "--demo", str(far.save(tmp_path / "far.json")), "--out", str(tmp_path / "o")]) == 2
    assert "out of the arm's reach" in capsys.readouterr().err


def test_teleop_without_a_terminal_is_refused_clearly(capsys):
    from excavsim.apps.playback.teleop import tty_keys
    with pytest.raises(ExcavsimError, match="not a terminal"):
        next(tty_keys(io.StringIO("ssss")))
    assert main(["playback", "--keys", "ss"]) == 2
    assert "--teleop" in capsys.readouterr().err
    assert main(["playback", "--teleop", "--keys", "ssz"]) == 2  # a bad key, before the world is built
    assert "unknown key 'z'" in capsys.readouterr().err


class Capture:
    """An episode observer keeping the execution records (beside the recorder)."""

    def __init__(self):
        self.records = []

    def __getattr__(self, name):
        return lambda *a, **k: None

    def started(self, sim, rig, goal_mask, goal_z):
        self.sim, self.rig = sim, rig

    def dug(self, index, record, metrics):
        self.records.append(record)


def test_a_dig_read_back_from_a_rerun_recording_is_the_executed_cut(tmp_path):
    from excavsim.handoff.episode import ObserverGroup
    from excavsim.apps.playback.machines import adapter_for
    from excavsim.loop.scenario import EpisodeSpec, run_spec
    from excavsim.record import TrenchRecorder
    from excavsim.record.demo_reading import read_dig
    spec = EpisodeSpec(name="rrd-demo", goal="small", dig_budget=1,
                       sensing={"map": {"n_scans": 1}, "scanner": {"n_azimuth": 60, "n_elevation": 60}},
                       planner={"grid": {"k_min_m": 1.8, "k_max_m": 2.6, "k_step_m": 0.2, "alpha_step_deg": 15.0,
                                         "d1_step_m": 0.04}})
    path, cap = tmp_path / "ep.rrd", Capture()
    run_spec(spec, observer=ObserverGroup(TrenchRecorder(path), cap))
    rec = cap.records[0]
    assert len(rec.executed_path) > 100
    dig = read_dig(path, 1)
    demo = adapter_for().demonstration_from_signals(dig.joint_times, dig.joints, dig.ft_times, dig.ft_tip,
                                                    dig.path_world, source=f"{path}, dig 1")
    ref = demonstration_from_record(rec, arm=cap.rig.arm, ft=cap.rig.executor.ft, waist=demo.waist,
                                    dt=cap.sim.control_dt)
    # the same cut: its length within two recorder samples (10 Hz), the ends within 3 cm, the force peak within 15 %
    assert demo.times[-1] == pytest.approx(ref.times[-1], abs=0.25)
    assert np.linalg.norm(demo.pose[0, :2] - ref.pose[0, :2]) < 0.03
    assert np.linalg.norm(demo.pose[-1, :2] - ref.pose[-1, :2]) < 0.03
    peak, ref_peak = (np.linalg.norm(d.force, axis=1).max() for d in (demo, ref))
    assert peak == pytest.approx(ref_peak, rel=0.15)
    back = load_demonstration(demo.save(tmp_path / "rrd.json"))
    assert len(back.times) == len(demo.times)
    with pytest.raises(ExcavsimError, match="allowed: 1..1"):
        read_dig(path, 2)
    assert main(["playback", "--from-rrd", str(path), "--out", str(tmp_path / "out")]) == 0
    assert load_demonstration(tmp_path / "out" / "rrd_demonstration.json").source.endswith("dig 1")


def test_a_teleoperation_session_can_be_recorded_with_its_force_plot(tmp_path):
    from rerun.chunk import RrdReader

    from excavsim.apps.playback.teleop import teleoperate
    from excavsim.record import TrenchRecorder
    path = tmp_path / "teleop.rrd"
    demo = teleoperate("s" * 12 + "a" * 6, observer=TrenchRecorder(path))
    rows = {}
    for chunk in RrdReader(path).stream().to_chunks():
        if not chunk.is_static:
            rows[chunk.entity_path] = rows.get(chunk.entity_path, 0) + chunk.num_rows
    # the F/T plot and the arm at the recorder's 10 Hz over the session (the go-home move before it included)
    for entity in ("/ft/force/x", "/joint_deg/shoulder"):
        assert rows.get(entity, 0) >= 10 * demo.times[-1], entity


def test_the_terminal_reader_gives_single_key_presses_from_a_pseudo_terminal():
    import os
    import pty
    import termios
    import threading
    import time

    from excavsim.apps.playback.teleop import tty_keys
    master, slave = pty.openpty()
    stream = io.TextIOWrapper(io.BufferedReader(io.FileIO(slave, "r", closefd=False)), encoding="utf-8")
    before = termios.tcgetattr(slave)

    def type_keys():  # one key at a time, after the reader has put the terminal in cbreak mode
        time.sleep(0.3)
        for c in b"sad" + FINISH.encode() + b"ww":
            os.write(master, bytes([c]))
            time.sleep(0.02)

    writer = threading.Thread(target=type_keys, daemon=True)
    writer.start()
    try:
        assert list(tty_keys(stream)) == ["s", "a", "d", FINISH]  # no Enter needed; ends at the finish key
        assert termios.tcgetattr(slave) == before  # the terminal is restored
    finally:
        writer.join(2.0)
        os.close(master)
        os.close(slave)
