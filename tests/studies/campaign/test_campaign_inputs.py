"""One campaign, one version: the same episode twice in one worker is the same to the bit, and a model or
configuration changed under a running campaign stops it instead of mixing two versions in its results
(excavsim.studies.campaign.inputs: the truck-loading campaign whose heavy clay seed 0 differed between its
tuned and untuned runs from the first pass had the 25 t excavator's model changed by a merge between them)."""

from __future__ import annotations

import json
import shutil

import pytest

from excavsim import constants
from excavsim.loop.scenario import merge
from excavsim.studies.campaign import inputs
from excavsim.studies.campaign import runner as cmp

OLD_ARMATURE = 'damping="136.476468138" armature="13.6476468138"'  # the linkage before the merge of 17:22
NEW_ARMATURE = 'damping="136.476468138" armature="136.476468138"'


def _pass_rows(rec):
    assert rec["status"] == "ok", rec["error"]
    return [{k: v for k, v in row.items() if k != "wall_s"} for row in rec["digs"]]


def test_a_model_changed_between_two_episodes_of_one_worker_is_caught_not_mixed_in(tmp_path, monkeypatch):
    """Heavy clay seed 0, one truck-loading pass, three times in one process (a campaign worker): twice
    the same to the bit (nothing carried from episode to episode); then the machine's model file changes
    as the merge changed it, and the same episode unchecked gives another first pass (what the campaign
    recorded), while the checked task refuses to run and names the file."""
    models = tmp_path / "models"
    shutil.copytree(constants.MODELS_DIR / "excavator_25t", models / "excavator_25t")
    monkeypatch.setattr(constants, "MODELS_DIR", models)
    monkeypatch.setattr(inputs, "default_roots", lambda: [(models, ("**/*.xml",))])
    spec = cmp.parse_campaign({"name": "determ", "grid": {"seed": [0]},
                               "base": {"task": "truck_loading", "machine": "excavator_25t", "soil": "heavy_clay",
                                        "dig_budget": 1}})
    (ep,) = cmp.expand_grid(spec)
    task = cmp._task(ep, tmp_path, False, inputs.digest())
    first = cmp.run_episode_task(task)
    again = cmp.run_episode_task(task)
    assert _pass_rows(first) == _pass_rows(again) and len(_pass_rows(first)) == 1
    assert first["inputs"] == again["inputs"] == inputs.combined(task["inputs"])

    xml = models / "excavator_25t" / "excavator_25t.xml"
    text = xml.read_text()
    assert text.count(NEW_ARMATURE) == 2
    xml.write_text(text.replace(NEW_ARMATURE, OLD_ARMATURE))
    mixed = cmp.run_episode_task(cmp._task(ep, tmp_path, False, None))  # unchecked: the campaign before the fix
    assert _pass_rows(mixed)[0]["dig_s"] != _pass_rows(first)[0]["dig_s"]

    checked = cmp.run_episode_task(task)
    assert checked["status"] == "error" and checked["summary"] is None and checked["log"] == []
    assert checked["inputs_changed"] == ["models/excavator_25t/excavator_25t.xml"]
    assert checked["inputs_changed_when"] == "before"
    assert "models/excavator_25t/excavator_25t.xml" in checked["error"]
    json.dumps(checked, allow_nan=False)


@pytest.fixture
def fake_episodes(tmp_path, monkeypatch):
    """Episodes run in this process (no workers) by a stand-in for run_spec that, while ``edits`` holds
    episode ids, rewrites the one input file during those episodes; the inputs are that file alone."""
    configs = tmp_path / "configs"
    configs.mkdir()
    soils = configs / "soils.yaml"
    soils.write_text("soils: {a: 1}\n")
    monkeypatch.setattr(inputs, "default_roots", lambda: [(configs, ("*.yaml",))])
    edits: set[str] = set()

    def run_spec(spec, *, progress, observer):
        if f"seed{spec.seed}" in edits:
            soils.write_text(soils.read_text() + f"# changed during seed {spec.seed}\n")
        return spec.seed

    monkeypatch.setattr(cmp, "run_spec", run_spec)
    monkeypatch.setattr(cmp, "episode_summary", lambda seed, task: {"task": task, "end": "budget", "digs": 1, "seed": seed})
    monkeypatch.setattr(cmp, "dig_rows", lambda _r, _task: [])
    monkeypatch.setattr(cmp, "_local_results", lambda tasks, workers, say: (cmp.run_episode_task(t) for t in tasks))
    monkeypatch.setattr(cmp, "plot_campaign", lambda spec, rows, out: [])
    return edits


def test_a_campaign_whose_inputs_change_stops_and_its_resume_reruns_what_the_old_ones_made(tmp_path, fake_episodes):
    spec = cmp.parse_campaign({"name": "moving", "base": {"goal": "small", "dig_budget": 1},
                               "grid": {"seed": [0, 1, 2]}})
    ids = [e.id for e in cmp.expand_grid(spec)]
    out = tmp_path / "out"
    fake_episodes.add("seed1")
    with pytest.raises(cmp.InputsChanged, match=r"configs/soils\.yaml; seen during episode seed1-.*--resume"):
        cmp.run_campaign(spec, out, progress=None)
    assert sorted(p.stem for p in (out / "episodes").glob("*.json")) == [ids[0]]  # the change's episode is not kept
    old = json.loads((out / "episodes" / f"{ids[0]}.json").read_text())["inputs"]

    fake_episodes.clear()
    lines: list[str] = []
    report = cmp.run_campaign(spec, out, resume=True, progress=lines.append)
    assert report.ran == 3 and report.errors == 0
    assert any("1 result(s) were made with other code" in line for line in lines)
    assert [p.name for p in (out / "episodes" / "stale").iterdir()] == [f"{ids[0]}.json"]
    made = {json.loads((out / "episodes" / f"{i}.json").read_text())["inputs"] for i in ids}
    assert len(made) == 1 and made != {old}

    again = cmp.run_campaign(spec, out, resume=True, progress=None)  # nothing changed: nothing runs
    assert again.ran == 0


def test_the_digest_names_added_removed_and_changed_files(tmp_path):
    (tmp_path / "a.yaml").write_text("a: 1\n")
    (tmp_path / "b.yaml").write_text("b: 1\n")
    roots = [(tmp_path, ("*.yaml",))]
    before = inputs.digest(roots)
    (tmp_path / "a.yaml").write_text("a: 2\n")
    (tmp_path / "b.yaml").unlink()
    (tmp_path / "c.yaml").write_text("c: 1\n")
    after = inputs.digest(roots)
    name = tmp_path.name
    assert inputs.changed(before, after) == [f"{name}/a.yaml", f"{name}/b.yaml", f"{name}/c.yaml"]
    assert inputs.changed(before, before) == [] and inputs.combined(before) != inputs.combined(after)
    assert inputs.describe([str(i) for i in range(7)], limit=2) == "0, 1 and 5 more"


@pytest.mark.parametrize("base, other", [
    ({"task": "truck_loading", "machine": "excavator_25t", "soil": "heavy_clay", "dig_budget": 1,
      "truck_loading": {"tuning": {"tune": False}}},
     {"soil": "lean_clay", "seed": 3, "truck_loading": {"tuning": {"tune": True}}}),
    ({"task": "pile_loading", "dig_budget": 1}, {"seed": 3}),
], ids=["truck_loading", "pile_loading"])
def test_an_episode_after_another_in_one_worker_is_the_same_as_before_it(base, other):
    """A worker's second episode does not inherit the first's state: episode B, a different episode A, B
    again, in one process, give B's passes (or digs) and summary twice to the bit (wall times aside)."""
    def run(spec):
        spec = dict(spec)
        grid = {"seed": [spec.pop("seed", 0)]}
        (ep,) = cmp.expand_grid(cmp.parse_campaign({"name": "order", "base": spec, "grid": grid}))
        rec = cmp.run_episode_task(cmp._task(ep, constants.REPO_ROOT, False, None))
        assert rec["status"] == "ok", rec["error"]
        return ({k: v for k, v in rec["summary"].items() if not k.endswith("wall_s")}, _pass_rows(rec))

    b = run(base)
    run(merge(base, other))
    assert run(base) == b
