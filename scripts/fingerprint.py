"""The behaviour fingerprint of a checkout: proof that a restructuring changed no behaviour.

``record DIR`` runs ``excavsim trench`` (the default episode, saving every scanned map),
``trench --goal small --seed 3`` (likewise), ``regress`` (writing every scenario's metrics to full
precision), ``plan --no-figures``, ``cycle``, ``demo``, the tiny campaign
(``configs/campaigns/tiny.yaml``, one worker) and episodes of the dig-level environments (the
Gymnasium one with the planner's action and with seeded random actions, the dm_env one with the
planner's action) with this interpreter and this checkout, and keeps their output in ``DIR``.
``compare A B`` compares two fingerprints: the printed tables and summaries line by line with the
timings masked, the regression metrics, the campaign's episode results and the environments'
observations, rewards and infos exactly (wall times, planning times and versions left out), and
every scanned map bit for bit. Episodes
are deterministic for a seed on one machine, so a pure refactoring must compare identical there;
across machines floating-point differences grow into different digs, and a comparison means
nothing.

    git worktree add /tmp/old HEAD~1                       # the commit before the change
    python scripts/fingerprint.py record /tmp/before --repo /tmp/old
    python scripts/fingerprint.py record /tmp/after        # this checkout
    python scripts/fingerprint.py compare /tmp/before /tmp/after

Takes a few minutes per fingerprint on 2 cores.
"""

from __future__ import annotations

import argparse
import difflib
import json
import os
import pathlib
import re
import shutil
import subprocess
import sys

import numpy as np

REPO = pathlib.Path(__file__).resolve().parent.parent
RUNS = {  # output file -> arguments of the excavsim command
    "trench_default.txt": ["trench", "--save-maps", "{dir}/maps_default"],
    "trench_small3.txt": ["trench", "--goal", "small", "--seed", "3", "--save-maps", "{dir}/maps_small3"],
    "regress.txt": ["regress", "--all", "--update", "--baseline", "{dir}/regress_full.json"],
    "plan.txt": ["plan", "--no-figures"],
    "cycle.txt": ["cycle"],
    "demo.txt": ["demo"],
    "campaign_tiny.txt": ["campaign", "configs/campaigns/tiny.yaml", "--out", "{dir}/campaign_tiny", "--workers", "1"],
    # every task and machine: the campaign over tasks (its JSON results compared exactly) and every shipped spec
    "campaign_tasks.txt": ["campaign", "configs/campaigns/tasks.yaml", "--out", "{dir}/campaign_tasks", "--workers",
                           "1"],
    **{f"spec_{p.stem}.txt": ["run", f"configs/specs/{p.name}"]
       for p in sorted((REPO / "configs" / "specs").glob("*.yaml"))},
}
# keys of JSON results that differ run to run (wall-clock times, versions, dates, paths) or checkout to checkout
# (a campaign result's inputs: the digest of the code, models and configurations it ran with)
VOLATILE_KEYS = re.compile(r"wall|planning_s|seconds|version|time_utc|date|started|finished_at|host|pid|path|elapsed"
                           r"|^inputs$")
# wall-clock times, and the lines that name the checkout or the output directory
TIMING = re.compile(r"\d+\.\d+ s\b|\d+\.\d+ s wall|\(\d+ s\)|ETA \d+ min \d+ s")
VOLATILE = ("maps saved in", "baseline written", "golden scenarios of", "recorded to")


def record(out: pathlib.Path, repo: pathlib.Path = REPO) -> None:
    """Run the commands of :data:`RUNS` in checkout ``repo`` and keep their output (and the maps and
    metrics) in ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    shutil.copy(repo / "configs" / "regress" / "baseline.json", out / "regress_full.json")
    env = {**os.environ, "MUJOCO_GL": "disable", "PYTHONPATH": str(repo)}
    for name, args in RUNS.items():
        cmd = [sys.executable, "-m", "excavsim.cli", *(a.format(dir=out) for a in args)]
        print("running", " ".join(cmd[2:]), flush=True)
        done = subprocess.run(cmd, cwd=repo, env=env, capture_output=True, text=True)
        text = (done.stdout + done.stderr).replace(str(out), "DIR")
        (out / name).write_text(text + f"exit status {done.returncode}\n")
    print("running the dig environments", flush=True)
    done = subprocess.run([sys.executable, __file__, "_envs", str(out / "envs")], cwd=repo, env=env,
                          capture_output=True, text=True)
    (out / "envs.txt").write_text(done.stdout + done.stderr + f"exit status {done.returncode}\n")


def _jsonable(x):
    """Observations, rewards and infos as JSON (arrays as lists with their dtype, NaN as a string)."""
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return {"dtype": str(x.dtype), "shape": list(x.shape), "data": _jsonable(x.ravel().tolist())}
    if isinstance(x, (np.generic,)):
        return _jsonable(x.item())
    if isinstance(x, float):
        return repr(x) if x != x or x in (float("inf"), float("-inf")) else x
    return x


def record_envs(out: pathlib.Path) -> None:
    """Episodes of the dig-level environments, every observation, reward and info kept in
    ``out/*.json``: TrenchDigEnv on the small trench with the planner's action (seeds 0, 1) and with
    seeded random actions (seed 2), and the dm_env face with the planner's action (seed 3)."""
    import gymnasium as gym

    import excavsim.envs  # noqa: F401  (registers the environments)
    try:
        from excavsim.tasks.trench.envs.dm import DmTrenchDig
    except ImportError:  # a checkout from before the environments moved into their tasks' folders
        from excavsim.envs.dm import DmTrenchDig

    out.mkdir(parents=True, exist_ok=True)
    spec = {"goal": "small", "dig_budget": 3, "sensing": {"map": {"n_scans": 2}}}
    env = gym.make("excavsim/TrenchDig-v0", spec=spec).unwrapped
    # the actions from the core's bounds in the planner's units (float64): the float32 action space of
    # issue 36 would otherwise change the random and middle actions fed in, not the episodes' behaviour
    low, high = env.core.action_low.astype(float), env.core.action_high.astype(float)
    mid = (low + high) / 2
    for name, seed, random in (("gym_planner_0", 0, False), ("gym_planner_1", 1, False), ("gym_random_2", 2, True)):
        rng = np.random.default_rng(seed)
        obs, info = env.reset(seed=seed)
        steps = [{"obs": obs, "info": info}]
        done = False
        while not done:
            if random:
                action = rng.uniform(low, high)
            else:
                action = info["planner_action"] if info.get("planner_action") is not None else mid
            obs, reward, terminated, truncated, info = env.step(action)
            steps.append({"action": action, "obs": obs, "reward": reward, "terminated": terminated,
                          "truncated": truncated, "info": info})
            done = terminated or truncated
        (out / f"{name}.json").write_text(json.dumps(_jsonable(steps), indent=0, sort_keys=True))
        print(name, len(steps) - 1, "steps, end", info.get("episode", {}).get("end"))
    env.close()
    dm = DmTrenchDig(spec, seed=3)
    ts = dm.reset()
    steps = [{"obs": ts.observation, "type": int(ts.step_type)}]
    while not ts.last():
        ts = dm.step(mid)
        steps.append({"obs": ts.observation, "reward": ts.reward, "discount": ts.discount, "type": int(ts.step_type)})
    (out / "dm_mid_3.json").write_text(json.dumps(_jsonable(steps), indent=0, sort_keys=True))
    print("dm_mid_3", len(steps) - 1, "steps")
    dm.close()
    # loading from a pile, one step per dig, the loading planner's action
    env = gym.make("excavsim/LoadDig-v0", spec={"machine": "loader", "dig_budget": 2}).unwrapped
    obs, info = env.reset(seed=0)
    steps = [{"obs": obs, "info": info}]
    done = False
    while not done:
        action = info.get("planner_action")
        if action is None:
            action = (env.action_space.low + env.action_space.high) / 2
        obs, reward, terminated, truncated, info = env.step(action)
        steps.append({"action": action, "obs": obs, "reward": reward, "info": info})
        done = terminated or truncated
    (out / "load_planner_0.json").write_text(json.dumps(_jsonable(steps), indent=0, sort_keys=True))
    print("load_planner_0", len(steps) - 1, "steps")
    env.close()
    # the joint-level environments (the T3's single dig, the TB035's valves): seeded random rates, 60 steps
    for name, env_id, kwargs in (("joint_dig_random_4", "excavsim/TrenchJointDig-v0", {}),
                                 ("excavator_random_5", "excavsim/ExcavatorJoint-v0", {})):
        env = gym.make(env_id, **kwargs).unwrapped
        seed = int(name.rsplit("_", 1)[1])
        rng = np.random.default_rng(seed)
        obs, info = env.reset(seed=seed)
        steps = [{"obs": obs, "info": info}]
        for _ in range(60):
            action = rng.uniform(env.action_space.low, env.action_space.high).astype(np.float32)
            obs, reward, terminated, truncated, info = env.step(action)
            steps.append({"action": action, "obs": obs, "reward": reward, "info": info})
            if terminated or truncated:
                break
        (out / f"{name}.json").write_text(json.dumps(_jsonable(steps), indent=0, sort_keys=True))
        print(name, len(steps) - 1, "steps")
        env.close()


# fields added to the episode specification whose defaults change no episode (issue 32: the task and
# machine of a spec); a result that records them at these values is the same as one from before them
NEW_SPEC_DEFAULTS = {"task": "trench", "machine": None, "loading": {}, "truck": {}}


def _strip(x):
    """A JSON result without its volatile keys (:data:`VOLATILE_KEYS`), and its spec without the new
    fields at their defaults (:data:`NEW_SPEC_DEFAULTS`)."""
    if isinstance(x, dict):
        if isinstance(x.get("spec"), dict):
            x = {**x, "spec": {k: v for k, v in x["spec"].items()
                               if k not in NEW_SPEC_DEFAULTS or v != NEW_SPEC_DEFAULTS[k]}}
        return {k: _strip(v) for k, v in x.items() if not VOLATILE_KEYS.search(k)}
    if isinstance(x, list):
        return [_strip(v) for v in x]
    if isinstance(x, str):
        return TIMING.sub("T", x)
    return x


RENAMES: dict[str, str] = {}  # old name -> new name (compare --rename OLD=NEW): tasks renamed between A and B
KEY_RENAMES: dict[str, str] = {}  # old field -> new field (compare --rename-key OLD=NEW), for JSON keys only


def _renamed(text: str) -> str:
    """``text`` with the old names of :data:`RENAMES` replaced by the new ones (as whole words, ``_`` counting
    as a separator) and runs of spaces folded (a renamed column is wider)."""
    for old, new in RENAMES.items():
        text = re.sub(rf"(?<![A-Za-z0-9]){re.escape(old)}(?![A-Za-z0-9])", new, text)
    if RENAMES:  # folded spaces; a campaign episode's id ends in a hash of its spec, whose shape changed
        text = re.sub(r"-[0-9a-f]{10}\b", "-HASH", re.sub(r" +", " ", text))
    return text


def _renamed_json(doc):
    """A JSON document with the renamed fields (keys) and names (in strings) of B."""
    if isinstance(doc, dict):
        return {KEY_RENAMES.get(k, k): _renamed_json(v) for k, v in doc.items()}
    if isinstance(doc, list):
        return [_renamed_json(v) for v in doc]
    return _renamed(doc) if isinstance(doc, str) else doc


def _lines(path: pathlib.Path) -> list[str]:
    return [_renamed(TIMING.sub("T", line)) for line in path.read_text().splitlines()
            if not any(v in line for v in VOLATILE)]


def _key(path: pathlib.Path) -> str:
    """A result file's episode: its name (a campaign's grid values), renamed; an environment's file name."""
    doc = json.loads(path.read_text())
    return _renamed(doc["name"]) if isinstance(doc, dict) and "name" in doc else path.name


NEW_SUMMARY_KEYS = {"task": "trench"}
"""Keys a summary gained when the tasks became plug-ins (every summary says its task), with the value a
summary of before would have had; a summary of A without one is compared as if it had it."""


def _with_new_keys(doc):
    """``doc`` with the :data:`NEW_SUMMARY_KEYS` a trench summary lacked (a dict holding ``end`` and ``digs``)."""
    if isinstance(doc, dict):
        doc = {k: _with_new_keys(v) for k, v in doc.items()}
        if "end" in doc and "digs" in doc:
            doc = {**{k: v for k, v in NEW_SUMMARY_KEYS.items() if k not in doc}, **doc}
        return doc
    if isinstance(doc, list):
        return [_with_new_keys(v) for v in doc]
    return doc


def _normal(doc):
    """A result for comparison: its volatile keys stripped, its id, recording path and spec left out (the
    spec's fields are inputs, and its shape may change with the code; what it ran is in ``params``), and the
    renamed names replaced."""
    doc = _with_new_keys(doc)
    if not RENAMES:
        return _strip(doc)
    if isinstance(doc, dict):
        doc = {k: v for k, v in doc.items() if k not in ("id", "spec", "recording")}
    return _renamed_json(_strip(doc))


def compare(a: pathlib.Path, b: pathlib.Path) -> int:
    """Print what differs between two fingerprints; returns the number of differences."""
    bad = 0
    def metrics(path: pathlib.Path) -> dict:  # the baseline's "written_by" names the module that wrote it
        doc = {k: v for k, v in json.loads(path.read_text()).items() if k != "written_by"}
        for scenario in doc.get("scenarios", {}).values():  # a trench scenario had no task before the plug-ins
            scenario["task"] = _renamed(scenario.get("task", "trench"))
        # golden scenarios are named after their task (load_loader_small became pile_loading_loader_small)
        doc["scenarios"] = {_renamed(name): v for name, v in doc.get("scenarios", {}).items()}
        return doc

    ma, mb = metrics(a / "regress_full.json"), metrics(b / "regress_full.json")
    added = sorted(set(mb.get("scenarios", {})) - set(ma.get("scenarios", {})))
    for name in [*RUNS, "envs.txt"]:
        if not (a / name).exists():
            print(f"new   {name}: not in {a}")
            continue
        if name == "regress.txt" and added:  # new golden scenarios: compared below by the old ones' metrics
            print(f"new   {name}: scenarios {', '.join(added)} added; the others compared by their metrics")
            continue
        la, lb = _lines(a / name), _lines(b / name)
        if la == lb:
            print(f"same  {name} ({len(la)} lines)")
        else:
            bad += 1
            print(f"DIFF  {name}")
            for line in list(difflib.unified_diff(la, lb, lineterm="", n=1))[:40]:
                print("     ", line)
    mb = {**mb, "scenarios": {k: v for k, v in mb.get("scenarios", {}).items() if k not in added}}
    same = ma == mb
    print(f"{'same ' if same else 'DIFF '} regress metrics (full precision)")
    bad += not same
    for maps in sorted(a.glob("maps_*")):
        files = sorted(maps.glob("*.npz"))
        other = sorted((b / maps.name).glob("*.npz"))
        if [f.name for f in files] != [f.name for f in other]:
            bad += 1
            print(f"DIFF  {maps.name}: {len(files)} maps against {len(other)}")
            continue
        differ = []
        for f in files:
            with np.load(f) as za, np.load(b / maps.name / f.name) as zb:
                differ += [f"{f.name}:{k}" for k in za.files if not np.array_equal(za[k], zb[k], equal_nan=True)]
        bad += len(differ)
        detail = ", ".join(differ) if differ else "bit for bit"
        print(f"{'DIFF ' if differ else 'same '} {maps.name}: {len(files)} maps, {detail}")
    for folder in ("campaign_tiny/episodes", "campaign_tasks/episodes", "envs"):
        # results matched by their episode's name (its grid values), ids aside: an id hashes the spec
        files = {_key(f): f for f in sorted((a / folder).glob("*.json"))}
        other = {_key(f): f for f in sorted((b / folder).glob("*.json"))}
        if not files or sorted(files) != sorted(other):
            bad += 1
            print(f"DIFF  {folder}: {len(files)} results against {len(other)}")
            continue
        differ = [other[k].name for k, f in files.items()
                  if _normal(json.loads(f.read_text())) != _normal(json.loads(other[k].read_text()))]
        bad += len(differ)
        print(f"{'DIFF ' if differ else 'same '} {folder}: {len(files)} results"
              + (f", differing: {', '.join(differ)}" if differ else ", exactly"))
    print("IDENTICAL" if not bad else f"{bad} DIFFERENCES")
    return bad


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    rec = sub.add_parser("record", help="run the commands and keep their output in DIR")
    rec.add_argument("dir", type=pathlib.Path)
    rec.add_argument("--repo", type=pathlib.Path, default=REPO, help="the checkout to run (default: this one)")
    cmp = sub.add_parser("compare", help="compare two fingerprints")
    cmp.add_argument("a", type=pathlib.Path)
    cmp.add_argument("b", type=pathlib.Path)
    cmp.add_argument("--rename", action="append", default=[], metavar="OLD=NEW",
                     help="a name A uses that B calls NEW (a renamed task), compared as the same")
    cmp.add_argument("--rename-key", action="append", default=[], metavar="OLD=NEW",
                     help="a field (a JSON key) A uses that B calls NEW")
    envs = sub.add_parser("_envs", help="(internal) run the environments' episodes into DIR")
    envs.add_argument("dir", type=pathlib.Path)
    args = parser.parse_args(argv)
    if args.command == "_envs":
        record_envs(args.dir)
        return 0
    if args.command == "record":
        record(args.dir, args.repo.resolve())
        return 0
    RENAMES.update(pair.split("=", 1) for pair in args.rename)
    KEY_RENAMES.update(pair.split("=", 1) for pair in args.rename_key)
    return 1 if compare(args.a, args.b) else 0


if __name__ == "__main__":
    sys.exit(main())
