"""The thesis' experiments by command (§7.2.2, Figs. 113-117): configurations, outputs, bad names."""

from __future__ import annotations

import csv

import pytest

from excavsim.cli import main
from excavsim.config import ConfigError
from excavsim.studies.experiment import (ExperimentSpec, experiment_names, format_comparison, load_experiment,
                                      run_experiment)
from excavsim.loop.scenario import EpisodeSpec, resolve


def test_every_thesis_experiment_has_a_valid_configuration():
    assert experiment_names() == ["fig113", "fig114", "fig115", "fig116", "fig117"]
    planners = {}
    for name in experiment_names():
        exp = load_experiment(name)
        assert exp.name == name and exp.thesis
        planners[name] = [resolve(run) for run in exp.runs]  # every override applies
    fig113, = planners["fig113"]
    assert fig113.planner.objective == "lexicographic" and fig113.planner.auxiliary == "cumulative_torque"
    assert fig113.planner.volume_threshold == 0.95 and fig113.planner.volume_constraint
    assert fig113.robot.joints.wrist_pitch.torque_limit_nm == 1000.0
    a, b = planners["fig114"]
    assert a.robot.joints.wrist_pitch.torque_limit_nm == b.robot.joints.wrist_pitch.torque_limit_nm == 500.0
    assert a.spec.seed != b.spec.seed
    assert not any(p.planner.volume_constraint for name in ("fig115", "fig116", "fig117") for p in planners[name])
    assert planners["fig116"][0].planner.auxiliary == "peak_torque"
    assert planners["fig117"][0].planner.objective == "volume"


def test_an_unknown_experiment_names_the_known_ones(capsys):
    with pytest.raises(ConfigError, match="known: fig113, fig114"):
        load_experiment("fig999")
    assert main(["experiment", "fig999"]) == 2
    assert "fig117" in capsys.readouterr().err


def test_an_experiment_writes_its_sections_table_and_summary(tmp_path):
    run = EpisodeSpec(name="tiny", goal="small", seed=1, dig_budget=1,
                      planner={"objective": "lexicographic", "auxiliary": "cumulative_torque"})
    exp = ExperimentSpec(name="tiny", title="one dig", thesis="nothing", runs=[run])
    runs = run_experiment(exp, tmp_path)
    res = runs[0].result
    assert len(runs[0].sections) == len(res.digs) + 1  # the first map and one after every dig
    first, last = runs[0].sections[0].map_z, runs[0].sections[-1].map_z
    assert last.min() < first.min() - 0.02  # the dig shows in the section
    rows = list(csv.DictReader(open(tmp_path / "digs.csv")))
    assert len(rows) == len(res.digs)
    assert float(rows[0]["dug_l"]) == pytest.approx(1000 * res.digs[0].bucket_m3, rel=1e-3)
    assert (tmp_path / "sections.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    summary = (tmp_path / "summary.txt").read_text()
    assert "thesis: nothing" in summary and res.end in summary
    assert "tiny" in format_comparison({"tiny": (exp, runs)})


def test_seeds_never_repeat_an_episode_of_a_two_run_experiment(monkeypatch, tmp_path):
    """fig114's two runs start from seeds 0 and 1; with --seeds 3 they get 0, 2, 4 and 1, 3, 5 (a
    stride of 1 ran seeds 1 and 2 twice each)."""
    import excavsim.studies.experiment as experiment

    seen = []

    def fake_run(exp, out, progress=None):
        seen.extend(r.seed for r in exp.runs)
        raise SystemExit(0)  # stop before anything is written

    monkeypatch.setattr(experiment, "run_experiment", fake_run)
    with pytest.raises(SystemExit):
        main(["experiment", "fig114", "--seeds", "3", "--out", str(tmp_path)])
    assert seen == [0, 2, 4, 1, 3, 5]
