"""One playback driver for any machine (DiMaio 1998 ch. 6): the same record, play and report on the T3 (joint
servos, wrist F/T, Table 6.5) and on the TB035 (cylinders, their forces, Table 4.1), short demonstrations."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from excavsim.apps.playback.adapter import DEMO_SOIL, W
from excavsim.apps.playback.cylinder_arm import CylinderArm
from excavsim.apps.playback.driver import controllers, play, record_demonstration, run_playback
from excavsim.apps.playback.machines import adapter_for
from excavsim.apps.playback.servo_arm import ServoArm
from excavsim.cli import build_parser
from excavsim.config import get_soil
from excavsim.errors import ExcavsimError
from excavsim.robot.machine import MACHINES

SHORT_S = 2.0  # the free descent (1 s) and the first second of the cut


def short(machine: str):
    """``machine``'s own demonstration with its descent, cut after :data:`SHORT_S` seconds."""
    d = record_demonstration(0, machine=machine).with_approach(0.10, 1.0)
    n = int(round(SHORT_S / d.dt))
    return dataclasses.replace(d, times=d.times[:n], pose=d.pose[:n], force=d.force[:n])


@pytest.fixture(scope="module", params=["t3", "tb035"])
def machine_demo(request):
    return request.param, short(request.param)


def test_every_machine_of_the_registry_has_an_adapter_chosen_by_its_data():
    for name, machine in MACHINES.items():
        pm = adapter_for(name)
        assert pm.machine is machine
        assert isinstance(pm, CylinderArm if machine.hydraulics is not None else ServoArm), name
    assert isinstance(adapter_for("t3"), ServoArm) and isinstance(adapter_for("tb035"), CylinderArm)
    with pytest.raises(ExcavsimError, match="allowed"):
        adapter_for("no_such_machine")


def test_the_command_offers_the_registrys_machines(capsys):
    for name in MACHINES:
        assert build_parser().parse_args(["playback", "--machine", name]).machine == name
    with pytest.raises(SystemExit):
        build_parser().parse_args(["playback", "--machine", "no_such_machine"])
    assert ", ".join(repr(n) for n in MACHINES) in capsys.readouterr().err


def test_the_one_driver_plays_a_short_demonstration_back_on_the_t3_and_the_tb035(machine_demo):
    machine, demo = machine_demo
    pm = adapter_for(machine)
    assert demo.dt == pytest.approx(pm.control_dt())
    assert demo.times[-1] == pytest.approx(SHORT_S - demo.dt)
    laws = controllers(pm.impedance, sweep=False)
    assert [law.name for law in laws][0] == pm.impedance.position and laws[-1].name == pm.impedance.variable
    run, bucket = play(demo, get_soil(DEMO_SOIL), "same", laws[0], machine=machine)
    e = run.errors(W)
    assert run.outcome == "completed" and len(run.times) == len(demo.times)
    # position control in the demonstration's own soil follows the demonstrated path: within 8 cm RMS (the
    # TB035's drive lags 5 cm at 0.2 m/s; the T3's servos about 1.5 cm), through the descent into the soil
    assert e["pos_rms_m"] < 0.08
    assert run.pose[-1, 1] < run.pose[0, 1] - 0.05  # it came down from the approach and cut
    assert np.linalg.norm(run.force[-20:], axis=1).mean() > 100.0  # and felt the soil
    assert bucket >= 0.0


def test_the_one_driver_reports_each_machine_in_its_own_table(machine_demo, tmp_path, monkeypatch):
    """The experiment on a given short demonstration with position control only: a row per soil in the machine's
    table, the errors file with the machine's columns."""
    from excavsim.apps.playback import driver

    machine, demo = machine_demo
    pm = adapter_for(machine)
    monkeypatch.setattr(driver, "controllers", lambda impedance, sweep=True: [controllers(impedance, False)[0]])
    monkeypatch.setattr(type(pm), "chapter_report", False)  # no closing note: it compares three controllers
    lines = []
    table = run_playback(tmp_path, machine=machine, demo=demo, sweep=False, progress=lines.append)
    assert set(table) == {(s, pm.impedance.position) for s in ("same", "stiffer x3", "softer x0.3")}
    assert lines[-4:-1] == [pm.table_row(s, c, e) for (s, c), e in table.items()]
    header = (tmp_path / "errors.csv").read_text().splitlines()[0].split(",")
    assert header == ["soil", "controller", *pm.csv_columns]
    # a stiffer soil is harder to cut: position control meets more force there than in the softer one
    peak = {s: e["force_peak_n"] for (s, _), e in table.items()}
    assert peak["stiffer x3"] > peak["same"] > peak["softer x0.3"]


def test_a_demonstration_at_another_machines_rate_is_refused_before_any_playback(machine_demo):
    machine, demo = machine_demo
    other = "tb035" if machine == "t3" else "t3"
    lines = []
    with pytest.raises(ExcavsimError, match="control period"):
        run_playback(None, machine=other, demo=demo, progress=lines.append)
    assert not any("soil" in line and "controller" in line for line in lines)  # no table started


def test_every_excavator_cuts_the_tb035s_demonstration_scaled_by_its_reach():
    """The scripted cut is DiMaio's machine's (3.6 -> 2.6 m at 0.2 m deep on the TB035); every other excavator of
    the registry cuts it scaled by its reach, within its reach and joint limits, approach included."""
    from excavsim.apps.playback.cylinder_arm import ABOVE_M

    tb035 = adapter_for("tb035").rig(get_soil(DEMO_SOIL), 0).cut()
    assert [p.tolist() for p in tb035] == [[3.6, 0.0, 0.6], [3.6, -0.2, 0.6], [2.6, -0.2, 0.6], [2.6, -0.1, -0.4]]
    for name, machine in MACHINES.items():
        if machine.hydraulics is None:
            continue
        rig = adapter_for(name).rig(get_soil(DEMO_SOIL), 0)
        cut = rig.cut()
        scale = cut[0][0] / tb035[0][0]
        assert scale == pytest.approx(machine.table.x_max_m / MACHINES["tb035"].table.x_max_m)
        assert cut[2][1] == pytest.approx(-0.2 * scale)
        for pose in cut:  # raises if out of reach
            rig.joints_of(pose)
            rig.joints_of(pose + np.array([0.0, ABOVE_M, 0.0]))
