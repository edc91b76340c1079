"""The chapter-6 experiment over seeds (`excavsim playback --seeds`): the table per soil and metric and the
closing note that counts on how many seeds the variable impedance beats each fixed one (issue 24's claim)."""

from __future__ import annotations

import csv
import dataclasses

import numpy as np
import pytest

from excavsim.cli import main
from excavsim.errors import ExcavsimError
from excavsim.apps.playback.driver import seed_range, seed_table, seed_verdict
from excavsim.apps.playback.servo_arm import TABLE_6_5

FORCE, POSITION, VARIABLE = TABLE_6_5.low, TABLE_6_5.position, TABLE_6_5.variable


def test_seed_range_reads_ranges_and_lists_and_refuses_bad_specs():
    assert seed_range("0-7") == list(range(8))
    assert seed_range("3") == [3]
    assert seed_range("0-2, 5,1") == [0, 1, 2, 5]  # a seed given twice runs once
    for bad, why in (("3-1", "increasing"), ("x", "not a seed"), ("1-", "not a seed"), ("-2", "not a seed"),
                     ("0-64", "more than 64"), ("", "not a seed")):
        with pytest.raises(ExcavsimError, match=why):
            seed_range(bad)


def errors(pos_cm, force_n, w=1e6):
    return {"pos_rms_m": pos_cm / 100, "force_rms_n": force_n, "weighted_error": w * (pos_cm / 100) ** 2 + force_n ** 2}


def test_the_closing_note_counts_the_seeds_on_which_the_variable_impedance_wins():
    # seed 0: variable best in both errors; seed 1: its force error above low K's (the softer soil's case)
    tables = {0: {("soft", POSITION): errors(1.0, 500.0), ("soft", FORCE): errors(35.0, 470.0),
                  ("soft", VARIABLE): errors(0.5, 450.0)},
              1: {("soft", POSITION): errors(1.0, 500.0), ("soft", FORCE): errors(35.0, 460.0),
                  ("soft", VARIABLE): errors(5.0, 490.0)}}
    (line,) = seed_verdict(tables, ["soft"])
    assert "E lower than both fixed extremes on 2/2" in line
    assert "position RMS below low K's on 2/2, below position control's on 1/2" in line
    assert "force RMS below position control's on 2/2, below low K's on 1/2" in line
    assert "both errors below both extremes on 1/2" in line
    assert "mean 2.8 cm vs 1.0, 35.0" in line and "mean 470 N vs 500, 465" in line
    rows = seed_table(tables)
    force_rows = rows[rows.index("soft: force RMS error [N]") + 2:][:3]
    assert [r.split()[-3:] for r in force_rows] == [["500", "500", "500"], ["470", "460", "465"],
                                                    ["450", "490", "470"]]


@pytest.fixture(scope="module")
def short_demo(tmp_path_factory):
    """The chapter's demonstration cut short (the approach, the entry and 1 s of drag) to keep the test fast."""
    from excavsim.apps.playback.driver import record_demonstration
    d = record_demonstration(0).with_approach(0.10, 1.0)
    n = 200
    short = dataclasses.replace(d, times=d.times[:n], pose=d.pose[:n], force=d.force[:n])
    return short.save(tmp_path_factory.mktemp("demo") / "short.json")


@pytest.mark.slow
def test_playback_over_seeds_prints_each_seed_and_the_mean_and_writes_them(short_demo, tmp_path, capsys,
                                                                          monkeypatch):
    from excavsim.apps.playback import driver
    # the three controllers the closing note compares (the moderate one left out: each playback builds a world)
    three = [law for law in driver.controllers(TABLE_6_5, False) if law.name in (POSITION, FORCE, VARIABLE)]
    monkeypatch.setattr(driver, "controllers", lambda impedance, sweep=True: three)
    out = tmp_path / "o"
    assert main(["playback", "--demo", str(short_demo), "--seeds", "0,3", "--no-sweep", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    with open(out / "seeds.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 2 * 3 * 3 and {r["seed"] for r in rows} == {"0", "3"}
    # the printed mean is the mean of the seeds' values in the file (the low K force error: seeds differ in noise)
    vals = [float(r["force_rms_n"]) for r in rows if r["soil"] == "softer x0.3" and r["controller"] == FORCE]
    lines = text.splitlines()
    block = lines[lines.index("softer x0.3: force RMS error [N]") + 1:]
    assert block[0].split() == ["controller", "seed", "0", "seed", "3", "mean"]
    row = next(r for r in block if r.strip().startswith(FORCE)).split()
    assert float(row[-1]) == pytest.approx(np.mean(vals), abs=0.6)
    assert [float(x) for x in row[-3:-1]] == pytest.approx(vals, abs=0.6)
    assert "stiffer x3 over 2 seeds:" in text and "softer x0.3 over 2 seeds:" in text


def test_seeds_cannot_be_combined_with_a_single_seed_or_teleoperation(capsys):
    assert main(["playback", "--seeds", "0-1", "--seed", "2"]) == 2
    assert "--seeds" in capsys.readouterr().err
    assert main(["playback", "--seeds", "0-1", "--teleop"]) == 2
    assert main(["playback", "--seeds", "7-2"]) == 2
    assert "increasing" in capsys.readouterr().err
