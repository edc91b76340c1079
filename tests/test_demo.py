"""The demo job: the servos carry the arm through the scripted Cartesian moves."""

from __future__ import annotations

import numpy as np
import pytest

from excavsim.cli import main
from excavsim.config import load_robot_config
from excavsim.errors import ExcavsimError
from excavsim.loop.demo import DEMO_MOVES, Move, format_summary, run_demo
from excavsim.world.scene import build_physics


@pytest.fixture(scope="module")
def summary():
    robot = load_robot_config()
    return run_demo(build_physics(robot), robot)


def test_demo_reaches_every_scripted_pose(summary):
    assert [r.name for r in summary["moves"]] == [m.name for m in DEMO_MOVES]
    for r in summary["moves"]:
        assert r.tip_error_mm < 1.0, r  # the servos settle on the IK target (MuJoCo's site vs ours)
        assert r.pitch_error_deg < 0.1, r


def test_demo_stays_within_the_relief_limits(summary):
    for name, peak in summary["peak_torque_nm"].items():
        assert 0 < peak <= summary["torque_limit_nm"][name] + 1e-6, name


def test_demo_summary_prints_a_table(summary):
    text = format_summary(summary)
    assert "wrist_pitch" in text and "real-time factor" in text


def test_an_unreachable_demo_move_is_refused_before_moving():
    robot = load_robot_config()
    physics = build_physics(robot)
    q0 = physics.data.qpos.copy()
    with pytest.raises(ExcavsimError, match="far away"):
        run_demo(physics, robot, moves=[Move("far away", 0.0, (4.5, 1.0, 0.0))])
    np.testing.assert_array_equal(physics.data.qpos, q0)


def test_cli_demo_runs(capsys):
    assert main(["demo"]) == 0
    out = capsys.readouterr().out
    assert "swing back" in out and "peak torque" in out
