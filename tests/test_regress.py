"""The regression suite: a baseline is written, matched by the same run, and a weakened planner is flagged."""

from __future__ import annotations

import json

import pytest
import yaml

from excavsim.cli import main
from excavsim.loop.regress import METRICS, Change, compare

TINY = {
    "name": "tiny", "goal": "small", "seed": 0, "dig_budget": 1,
    "sensing": {"map": {"n_scans": 2}, "scanner": {"n_azimuth": 80, "n_elevation": 80}},
    "planner": {"grid": {"k_min_m": 1.7, "k_max_m": 2.7, "alpha_step_deg": 10.0, "d1_step_m": 0.02}},
}


def test_compare_judges_only_the_worse_direction_beyond_tolerance():
    base = {"s": {m: 10.0 for m in METRICS}}
    now = {"s": dict(base["s"], removed_fraction=10.0 - 0.2, digs=10.0 - 3, overdig_max_cm=10.0 + 0.5)}
    verdicts = {c.metric: c.verdict for c in compare(base, now)}
    assert verdicts["removed_fraction"] == "regression"  # higher is better, 0.2 below, tolerance 0.05
    assert verdicts["digs"] == "improved"
    assert verdicts["overdig_max_cm"] == "changed"  # worse but within its 1 cm tolerance
    assert verdicts["efficiency"] == "same"
    assert compare({"gone": {}}, {})[0] == Change("gone", "-", None, None, "missing")


def test_regress_flags_a_deliberately_weakened_planner(tmp_path, capsys):
    scen = tmp_path / "tiny.yaml"
    scen.write_text(yaml.safe_dump(TINY))
    assert main(["regress", "--dir", str(tmp_path), "--update"]) == 0
    baseline = json.loads((tmp_path / "baseline.json").read_text())
    assert baseline["tiny"]["dug_l_per_dig"] > 5.0
    capsys.readouterr()
    # the planner may fill only 30 % of the bucket: each dig brings less
    scen.write_text(yaml.safe_dump({**TINY, "planner": {**TINY["planner"], "fill_fraction": 0.3}}))
    assert main(["regress", "--dir", str(tmp_path)]) == 1
    out = capsys.readouterr()
    assert "dug_l_per_dig" in out.out and "regression" in out.out and "REGRESSION" in out.err


def test_only_runs_and_judges_the_named_scenarios(tmp_path, capsys):
    """``--only NAME`` on an unchanged tree exits 0: the scenarios it skips are not "missing"."""
    for name in ("a", "b"):
        (tmp_path / f"{name}.yaml").write_text(yaml.safe_dump({**TINY, "name": name}))
    assert main(["regress", "--dir", str(tmp_path), "--update"]) == 0
    capsys.readouterr()
    assert main(["regress", "--dir", str(tmp_path), "--only", "a"]) == 0
    out = capsys.readouterr().out
    assert "[1/1] a:" in out and "missing" not in out and "no regression" in out
    assert compare({"a": {}, "b": {}}, {"a": {}}, partial=True) == [
        Change("a", m, None, None, "new") for m in METRICS]


def test_regress_refuses_an_empty_directory_and_unknown_scenarios(tmp_path, capsys):
    assert main(["regress", "--dir", str(tmp_path)]) == 2
    assert "no regression scenarios" in capsys.readouterr().err
    (tmp_path / "a.yaml").write_text(yaml.safe_dump(TINY))
    assert main(["regress", "--dir", str(tmp_path), "--only", "b"]) == 2
    assert "unknown scenario" in capsys.readouterr().err


def test_a_scenario_with_a_bad_override_names_the_field(tmp_path, capsys):
    (tmp_path / "bad.yaml").write_text(yaml.safe_dump({**TINY, "planner": {"fill_fraction": -1.0}}))
    assert main(["regress", "--dir", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "fill_fraction" in err and "planner" in err


@pytest.mark.parametrize("bad", [{"soil": "peat"}, {"goal": "zigzag"}, {"planner": {"grid": 3}}])
def test_episode_specs_refuse_bad_input_clearly(tmp_path, bad, capsys):
    from excavsim.config import ConfigError
    from excavsim.loop.scenario import EpisodeSpec, ResolvedSpec

    with pytest.raises(ConfigError) as err:
        ResolvedSpec(EpisodeSpec.model_validate({**TINY, **bad}))
    assert any(word in str(err.value) for word in ("peat", "zigzag", "grid"))
