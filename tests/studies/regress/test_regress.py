"""The regression suite: the statistics on synthetic samples, the baseline and A/B modes on a tiny
scenario of very short episodes, and the errors (exit status 2) that name what is allowed."""

from __future__ import annotations

import json
import subprocess

import numpy as np
import pytest
import yaml

from excavsim import constants
from excavsim.cli import main
from excavsim.config import ConfigError
from excavsim.errors import ExcavsimError
from excavsim.studies.regress import stats as rs
from excavsim.loop import catalog
from excavsim.studies.regress.suite import (BASELINE_FORMAT, Sample, compare, load_baseline,
                                           load_scenarios, parse_seeds, write_baseline)

# one dig of the small trench, a coarse planner grid, a small scanner: about half a second an episode
TINY = {
    "name": "tiny", "goal": "small", "seed": 0, "dig_budget": 1, "seeds": 4,
    "sensing": {"map": {"n_scans": 1}, "scanner": {"n_azimuth": 60, "n_elevation": 60}},
    "planner": {"grid": {"k_min_m": 1.8, "k_max_m": 2.6, "k_step_m": 0.2, "alpha_step_deg": 15.0, "d1_step_m": 0.04}},
}
# the planner may fill only 30 % of the bucket: each dig brings less
WORSE = {**TINY, "planner": {**TINY["planner"], "fill_fraction": 0.3}}


def _scenario_dir(path, **scenarios):
    path.mkdir(exist_ok=True)
    for name, data in scenarios.items():
        (path / f"{name}.yaml").write_text(yaml.safe_dump({**data, "name": name}))
    return path


def _json_run(argv, capsys):
    """Run ``excavsim ARGV --json``: its exit status and the JSON it printed (a failure shows stderr)."""
    code = main([*argv, "--json"])
    out = capsys.readouterr()
    assert out.out.strip(), f"exit status {code} and no JSON; stderr ends:\n{out.err[-3000:]}"
    return code, json.loads(out.out)


# -- the statistics, on synthetic per-seed numbers ------------------------------------------------------
REF = [10.0, 11.0, 12.5, 13.0, 14.0, 15.5, 16.0, 17.0]


@pytest.mark.parametrize("paired", [False, True])
def test_judge_flags_a_significant_worsening_beyond_the_tolerance_only(paired):
    def verdict(now, higher=True, tol=1.0):
        return rs.judge(REF, now, higher_is_better=higher, tolerance=tol, paired=paired).verdict

    ref = np.array(REF)
    assert verdict(ref - 5) == "regression"
    assert verdict(ref - 5, higher=False) == "improved"
    assert verdict(ref + 5) == "improved" and verdict(ref + 5, higher=False) == "regression"
    assert verdict(ref - 0.5) == "ok"  # consistently lower, but within the practical tolerance
    assert verdict(ref - 0.5, tol=0.0) == ("regression" if paired else "ok")  # paired sees a small shift
    assert verdict(list(REF)) == "same"
    j = rs.judge(REF, ref - 5, higher_is_better=True, tolerance=1.0, paired=paired)
    assert j.difference == pytest.approx(-5) and j.interval[1] < -1.0 and j.p_value < rs.ALPHA


def test_same_values_in_another_seed_order_are_the_same_unpaired_but_not_paired():
    shuffled = REF[::-1]
    assert rs.judge(REF, shuffled, higher_is_better=True, tolerance=0.0, paired=False).verdict == "same"
    assert rs.judge(REF, shuffled, higher_is_better=True, tolerance=0.0, paired=True).verdict == "ok"


def test_too_few_seeds_can_flag_nothing():
    assert rs.smallest_p(4, 4, paired=False) == pytest.approx(1 / 70)
    assert rs.smallest_p(4, 4, paired=True) > rs.ALPHA > rs.smallest_p(5, 5, paired=True)
    j = rs.judge([10.0, 11.0, 12.0], [1.0, 2.0, 3.0], higher_is_better=True, tolerance=0.0, paired=False)
    assert j.p_value >= rs.ALPHA and j.verdict == "ok"


@pytest.mark.parametrize("paired", [False, True])
def test_noise_alone_is_rarely_flagged(paired):
    """Two samples of one distribution: the false-positive rate stays at or below the test's level."""
    rng = np.random.default_rng(1)
    flagged = sum(rs.judge(rng.normal(0, 1, 8), rng.normal(0, 1, 8), higher_is_better=True, tolerance=0.0,
                           paired=paired).verdict == "regression" for _ in range(300))
    assert flagged / 300 <= rs.ALPHA
    assert flagged > 0 or paired  # not a test that can never fire (unpaired, tolerance 0: about 3 %)


def test_bootstrap_intervals_are_reproducible_and_cover_the_shift():
    ref, now = np.array(REF), np.array(REF) + 2.0
    a = rs.bootstrap_interval(ref, now, paired=False)
    assert a == rs.bootstrap_interval(ref, now, paired=False) and a[0] < 2.0 < a[1]
    assert rs.bootstrap_interval(ref, now, paired=True) == pytest.approx((2.0, 2.0))
    stats = rs.summarize([1.0, 2.0, 3.0, 4.0])
    assert stats["mean"] == 2.5 and stats["median"] == 2.5 and stats["values"] == [1.0, 2.0, 3.0, 4.0]


# -- samples, the baseline file, seeds ----------------------------------------------------------------
TASK_METRICS = {name: tuple(p.metrics) for name, p in catalog.plugins().items()}  # every task's judged metrics
METRICS = {m for ms in TASK_METRICS.values() for m in ms}


def _sample(seeds, **columns):
    rows = [{k: v[i] for k, v in columns.items()} for i in range(len(seeds))]
    return Sample(list(seeds), rows, catalog.DEFAULT_TASK)


def test_compare_pairs_by_seed_and_knows_new_and_missing_scenarios():
    values = {m: [1.0, 2.0, 3.0, 4.0, 5.0] for m in METRICS}
    ref = _sample([0, 1, 2, 3, 4], **values)
    now = _sample([4, 3, 2, 1, 0], **{m: v[::-1] for m, v in values.items()})  # the same episodes, listed backwards
    assert {c.verdict for c in compare({"s": ref}, {"s": now}, paired=True)} == {"same"}
    rows = compare({"s": ref, "gone": ref}, {"s": now, "fresh": now})
    assert [c.verdict for c in rows if c.scenario == "fresh"] == ["new"] * len(TASK_METRICS[catalog.DEFAULT_TASK])
    assert [(c.scenario, c.verdict) for c in rows if c.metric == "-"] == [("gone", "missing")]
    assert not [c for c in compare({"s": ref, "gone": ref}, {"s": now}, partial=True) if c.scenario == "gone"]


def test_each_task_is_judged_on_its_metrics_and_the_baseline_keeps_its_task(tmp_path):
    from excavsim.studies.regress.suite import load_baseline, write_baseline

    values = {m: [1.0, 2.0, 3.0, 4.0] for m in METRICS}
    samples = {task: Sample([0, 1, 2, 3], [{k: v[i] for k, v in values.items()} for i in range(4)], task)
               for task in TASK_METRICS}
    rows = compare(samples, samples)
    for task, metrics in TASK_METRICS.items():
        assert tuple(c.metric for c in rows if c.scenario == task) == metrics
    assert "cycle_s" in TASK_METRICS["dump_trial"] and "delivered_l" in TASK_METRICS["pile_loading"]
    assert not {"cycle_s", "delivered_l", "failed_digs"} & set(TASK_METRICS["trench"])
    write_baseline(tmp_path / "b.json", samples)
    doc = json.loads((tmp_path / "b.json").read_text())
    assert doc["scenarios"]["trench"]["task"] == "trench" and doc["scenarios"]["dump_trial"]["task"] == "dump_trial"
    assert set(doc["scenarios"]["pile_loading"]["metrics"]) == set(TASK_METRICS["pile_loading"])
    back = load_baseline(tmp_path / "b.json")
    assert {n: s.task for n, s in back.items()} == {t: t for t in TASK_METRICS}


def test_the_baseline_keeps_per_seed_values_and_refuses_other_formats(tmp_path):
    path = tmp_path / "baseline.json"
    values = {m: [1.0, 3.0, 2.0] for m in METRICS}
    write_baseline(path, {"s": _sample([5, 6, 7], end=["done", "budget", "done"], sim_s=[1.0, 2.0, 3.0], **values)})
    doc = json.loads(path.read_text())
    stats = doc["scenarios"]["s"]["metrics"]["removed_fraction"]
    assert doc["format"] == BASELINE_FORMAT and stats["values"] == [1.0, 3.0, 2.0] and stats["median"] == 2.0
    back = load_baseline(path)["s"]
    assert back.seeds == [5, 6, 7] and back.values("digs") == [1.0, 3.0, 2.0]
    assert back.ends() == {"budget": 1, "done": 2}
    path.write_text(json.dumps({"s": {"digs": 1}}))  # the single-episode format of before
    with pytest.raises(ExcavsimError, match="not a distribution baseline"):
        load_baseline(path)
    with pytest.raises(ExcavsimError, match="no baseline at"):
        load_baseline(tmp_path / "absent.json")


def test_seeds_come_from_the_file_or_the_command_line(tmp_path):
    assert parse_seeds("8") == 8 and parse_seeds("3-5") == [3, 4, 5] and parse_seeds("1,4") == [1, 4]
    for bad in ("0", "x", "5-", "1,1", "-3"):
        with pytest.raises(ExcavsimError, match="--seeds"):
            parse_seeds(bad)
    _scenario_dir(tmp_path, a={**TINY, "seed": 3}, b={**TINY, "seeds": [9, 2]})
    found = load_scenarios(tmp_path)
    assert found["a"].seeds == (3, 4, 5, 6) and found["b"].seeds == (9, 2)
    assert load_scenarios(tmp_path, seeds=2)["a"].seeds == (3, 4)
    assert found["a"].job(4)["spec"]["seed"] == 4 and "seeds" not in found["a"].job(4)["spec"]
    (tmp_path / "a.yaml").write_text(yaml.safe_dump({**TINY, "seeds": 0}))
    with pytest.raises(ConfigError, match="seeds"):
        load_scenarios(tmp_path)


# -- the two modes on a tiny scenario --------------------------------------------------------------------
@pytest.mark.slow
def test_baseline_mode_passes_an_unchanged_planner_and_flags_a_worsened_one(tmp_path, capsys):
    good = _scenario_dir(tmp_path / "good", tiny=TINY)
    assert main(["regress", "--dir", str(good), "--update"]) == 0
    baseline = json.loads((good / "baseline.json").read_text())
    assert baseline["scenarios"]["tiny"]["seeds"] == [0, 1, 2, 3]
    assert baseline["scenarios"]["tiny"]["metrics"]["dug_l_per_dig"]["mean"] > 10.0
    capsys.readouterr()
    # unchanged planner, other seeds: not flagged; timings printed
    assert main(["regress", "--dir", str(good), "--seeds", "4-7"]) == 0
    out = capsys.readouterr().out
    assert "seeds 4-7 (baseline seeds 0-3)" in out and "timings per episode (never judged)" in out
    assert "regression" not in out.split("regression =")[1].replace("no regression", "")
    bad = _scenario_dir(tmp_path / "bad", tiny=WORSE)
    code, doc = _json_run(["regress", "--dir", str(bad), "--baseline", str(good / "baseline.json")], capsys)
    assert code == 1 and doc["verdict"] == "regression" and doc["mode"] == "baseline"
    m = doc["scenarios"]["tiny"]["metrics"]["dug_l_per_dig"]
    assert m["verdict"] == "regression" and m["p_value"] < 0.05 and m["interval"][1] < -m["tolerance"]
    assert m["now"]["mean"] < 0.5 * m["baseline"]["mean"] and len(m["now"]["values"]) == 4
    assert {"scenario": "tiny", "metric": "dug_l_per_dig", "verdict": "regression"} in doc["failed"]


@pytest.mark.slow
def test_ab_mode_flags_a_worsened_planner_configuration_paired_by_seed(tmp_path, capsys):
    good = _scenario_dir(tmp_path / "good", tiny=TINY)
    bad = _scenario_dir(tmp_path / "bad", tiny=WORSE)
    code, doc = _json_run(["regress", "--dir", str(bad), "--against-dir", str(good), "--seeds", "5"], capsys)
    assert code == 1 and doc["mode"] == "against"
    tiny = doc["scenarios"]["tiny"]
    assert tiny["seeds"] == tiny["baseline_seeds"] == [0, 1, 2, 3, 4]
    for metric in ("removed_fraction", "dug_l_per_dig"):
        assert tiny["metrics"][metric]["verdict"] == "regression"
        assert tiny["metrics"][metric]["p_value"] == pytest.approx(1 / 32)  # every seed worse: Wilcoxon's floor


def _episode_code_is_committed() -> bool:
    """Whether the code and configuration episodes run are as in HEAD (the regression suite's own
    files aside): only then must ``--against HEAD`` give identical results."""
    done = subprocess.run(["git", "-C", str(constants.REPO_ROOT), "status", "--porcelain", "--", "excavsim",
                           "configs", "models", ":!excavsim/cli", ":!excavsim/studies/regress",
                           ":!configs/regress"], capture_output=True, text=True)
    return done.returncode == 0 and not done.stdout.strip()


def _our_worktrees() -> set[str]:
    """The temporary worktrees of ``--against`` that git knows of."""
    out = subprocess.run(["git", "-C", str(constants.REPO_ROOT), "worktree", "list"], capture_output=True,
                         text=True).stdout
    return {line.split()[0] for line in out.splitlines() if "excavsim-against-" in line}


@pytest.mark.slow
def test_against_head_runs_a_temporary_worktree_and_gives_identical_paired_results(tmp_path, capsys):
    d = _scenario_dir(tmp_path / "s", tiny=TINY)
    before = _our_worktrees()  # others' runs may have some
    code, doc = _json_run(["regress", "--dir", str(d), "--against", "HEAD", "--seeds", "2"], capsys)
    assert _our_worktrees() <= before  # ours is removed again
    assert doc["mode"] == "against" and doc["baseline_source"].startswith("git HEAD (")
    metrics = doc["scenarios"]["tiny"]["metrics"]
    assert doc["scenarios"]["tiny"]["seeds"] == doc["scenarios"]["tiny"]["baseline_seeds"] == [0, 1]
    assert set(metrics) == set(TASK_METRICS["trench"])
    if not _episode_code_is_committed():  # a developer's uncommitted change: HEAD may dig differently;
        return  # on a clean checkout (CI) the identity below is always asserted
    assert code == 0 and {m["verdict"] for m in metrics.values()} == {"same"}
    assert all(m["difference"] == 0 and m["interval"] == [0, 0] for m in metrics.values())


def test_the_run_at_a_ref_must_import_the_package_from_its_checkout(tmp_path):
    from excavsim.studies.regress.against import CheckoutRun

    with pytest.raises(ExcavsimError, match="imported excavsim from"):  # tmp_path has no excavsim/
        with CheckoutRun(tmp_path, [{"name": "x", "spec": {}}], label="nothing") as run:
            run.results()


def test_only_small_sand_on_the_unchanged_tree_exits_0(capsys):
    assert main(["regress", "--only", "small_sand", "--seeds", "3"]) == 0
    out = capsys.readouterr().out
    assert "small_sand: seeds 0-2 (baseline seeds 0-7)" in out and "straight_sand_volume" not in out


# -- errors: exit status 2 and a message that names what is allowed ---------------------------------------
def test_regress_errors_name_what_was_wrong_and_what_is_allowed(tmp_path, capsys):
    assert main(["regress", "--dir", str(tmp_path)]) == 2
    assert "no regression scenarios" in capsys.readouterr().err
    _scenario_dir(tmp_path, a=TINY, b=TINY)
    assert main(["regress", "--dir", str(tmp_path), "--only", "a", "zz"]) == 2
    err = capsys.readouterr().err
    assert "unknown scenario(s) zz" in err and "the scenarios are: a, b" in err
    assert main(["regress", "--dir", str(tmp_path)]) == 2
    assert "no baseline at" in capsys.readouterr().err
    assert main(["regress", "--dir", str(tmp_path), "--against", "no-such-ref-xyz"]) == 2
    err = capsys.readouterr().err
    assert "'no-such-ref-xyz' does not exist" in err and "HEAD~1" in err
    assert main(["regress", "--dir", str(tmp_path), "--seeds", "many"]) == 2
    assert "--seeds" in capsys.readouterr().err
    assert main(["regress", "--dir", str(tmp_path), "--update", "--against", "HEAD"]) == 2
    assert main(["regress", "--dir", str(tmp_path), "--against-dir", str(tmp_path / "none")]) == 2
    assert "no regression scenarios" in capsys.readouterr().err
    try:  # argparse refuses both A/B sources at once: status 2, returned or raised
        status = main(["regress", "--against", "HEAD", "--against-dir", str(tmp_path)])
    except SystemExit as exc:
        status = exc.code
    assert status == 2 and "not allowed with argument --against" in capsys.readouterr().err


def test_a_scenario_with_a_bad_override_names_the_field(tmp_path, capsys):
    (tmp_path / "bad.yaml").write_text(yaml.safe_dump({**TINY, "planner": {"fill_fraction": -1.0}}))
    (tmp_path / "baseline.json").write_text(json.dumps({"format": BASELINE_FORMAT, "scenarios": {}}))
    assert main(["regress", "--dir", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "fill_fraction" in err and "planner" in err


@pytest.mark.parametrize("bad", [{"soil": "peat"}, {"goal": "zigzag"}, {"planner": {"grid": 3}}])
def test_episode_specs_refuse_bad_input_clearly(tmp_path, bad, capsys):
    from excavsim.loop.scenario import EpisodeSpec, resolve

    spec = {k: v for k, v in TINY.items() if k != "seeds"}
    with pytest.raises(ConfigError) as err:
        resolve(EpisodeSpec.model_validate({**spec, **bad}))
    assert any(word in str(err.value) for word in ("peat", "zigzag", "grid"))
