"""Every tool on every task: the tools ask the plug-ins, so these tests cover every registered task and machine,
a task added tomorrow too. Each task and machine has a golden scenario (``regress``) and a specification
(``run``, ``validate``); a campaign over all of them with ``record: true`` runs and every recording passes
``rerun rrd verify``; ``regress --against HEAD`` runs over every golden scenario; every environment a task
contributes is registered."""

from __future__ import annotations

import json
import subprocess

import pytest
import yaml

from excavsim import constants
from excavsim.cli import main
from excavsim.loop import catalog
from excavsim.loop.scenario import load_spec
from excavsim.studies.regress.suite import load_scenarios
from excavsim.validate import validate_file

PAIRS = [(name, machine) for name, plugin in catalog.plugins().items() for machine in plugin.machines]
GOLDEN = load_scenarios()
SPECS = {p: load_spec(p) for p in sorted((constants.CONFIGS_DIR / "specs").glob("*.yaml"))}


def _golden(task: str, machine: str):
    """The first golden scenario of ``task`` on ``machine``."""
    return next(g for g in GOLDEN.values() if (g.spec.task, g.spec.machine_name) == (task, machine))


def test_every_task_and_machine_has_a_golden_scenario():
    have = {(g.spec.task, g.spec.machine_name) for g in GOLDEN.values()}
    assert set(PAIRS) <= have, f"no golden scenario (configs/regress/) of {sorted(set(PAIRS) - have)}"


def test_every_task_has_a_specification_that_validate_accepts():
    have = {spec.task for spec in SPECS.values()}
    assert set(catalog.names()) <= have, f"no specification (configs/specs/) of {sorted(set(catalog.names()) - have)}"
    for path in SPECS:
        assert validate_file(path)[0] == "spec"


@pytest.mark.parametrize("task", catalog.names())
def test_run_runs_a_short_episode_of_every_task(task, tmp_path, capsys):
    golden = _golden(task, catalog.plugin(task).machines[0])
    fields = {**golden.fields, "task": task, "seed": 0}
    if catalog.plugin(task).budget:
        fields["dig_budget"] = 1
    path = tmp_path / "spec.yaml"
    path.write_text(yaml.safe_dump(fields))
    assert main(["run", str(path)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("excavsim run: ") and len(out.splitlines()) > 1


def test_every_environment_of_every_task_is_registered():
    gymnasium = pytest.importorskip("gymnasium")
    import excavsim.envs  # noqa: F401  (registers them)

    for name, plugin in catalog.plugins().items():
        for env in plugin.environments:
            assert env.id in gymnasium.envs.registration.registry, f"{name}: {env.id} is not registered"


@pytest.mark.slow
def test_a_campaign_over_every_task_and_machine_records_every_episode(tmp_path):
    """One episode of every task on every machine (its golden scenario's fields, one dig or pass), recorded by
    each task's own recorder; every recording passes ``rerun rrd verify``."""
    from excavsim.studies.campaign.runner import load_campaign, run_campaign
    from tests.record.test_task_recordings import verify

    values = []
    for task, machine in PAIRS:
        fields = {**{k: v for k, v in _golden(task, machine).fields.items() if k not in ("name", "seed")},
                  "task": task, "machine": machine}
        if catalog.plugin(task).budget:
            fields["dig_budget"] = 1
        values.append(fields)
    path = tmp_path / "every.yaml"
    path.write_text(yaml.safe_dump({"name": "every", "record": True, "grid": {"task": values, "seed": [0]}}))
    report = run_campaign(load_campaign(path), tmp_path / "out", workers=2, progress=None)
    assert report.errors == 0, [r.get("error") for r in report.rows if r.get("status") != "ok"]
    recordings = sorted((tmp_path / "out" / "recordings").glob("*.rrd"))
    assert len(recordings) == len(PAIRS)
    for rrd in recordings:
        verify(rrd)
    tasks = {(r["task"], r["machine"]) for r in report.rows}
    assert tasks == set(PAIRS)


@pytest.mark.slow
def test_regress_against_head_runs_every_golden_scenario(capsys):
    """The A/B check of a change runs over every golden scenario, every task's (one seed each here)."""
    code = main(["regress", "--against", "HEAD", "--seeds", "1", "--json"])
    out = capsys.readouterr()
    doc = json.loads(out.out)
    assert set(doc["scenarios"]) == set(GOLDEN), out.err[-2000:]
    for name, scenario in doc["scenarios"].items():
        task = GOLDEN[name].spec.task
        assert set(scenario["metrics"]) == set(catalog.plugin(task).metrics), name
    changed = subprocess.run(["git", "-C", str(constants.REPO_ROOT), "status", "--porcelain", "--", "excavsim",
                              "configs", "models"], capture_output=True, text=True).stdout.strip()
    if not changed:  # a clean checkout (CI): HEAD is this tree, so every metric is the same
        assert code == 0 and {m["verdict"] for s in doc["scenarios"].values() for m in s["metrics"].values()} == {
            "same"}
