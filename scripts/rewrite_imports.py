"""Rewrite imports and dotted names after the move of issue 32 (one home per application and study).

The applications and studies that grew inside ``excavsim/loop/`` moved to ``excavsim/tasks/``,
``excavsim/apps/`` and ``excavsim/studies/`` (see :data:`MODULES`). A branch written against the old
paths is brought over by running this script on its files after the merge::

    python scripts/rewrite_imports.py            # excavsim/ tests/ scripts/ examples/ docs/ configs/ README.md ...
    python scripts/rewrite_imports.py FILE_OR_DIR ...
    python scripts/rewrite_imports.py --check    # list what would change, change nothing (exit 1 if any)

It rewrites, in every text file given (``.py``, ``.md``, ``.toml``, ``.yaml``, ``.yml``, ``.txt``,
``.cfg``, ``.rst``, ``Makefile``):

* ``from excavsim.loop import campaign as cmp`` -> ``from excavsim.studies.campaign import runner as cmp``
  (names of moved modules imported from their old parent, also inside parenthesised lists);
* every dotted name that starts with an old module: ``import excavsim.loop.truck``,
  ``from excavsim.loop.regress import X``, ``mock.patch("excavsim.loop.campaign.run_spec")``,
  ``:mod:`~excavsim.loop.samples``` ...;
* every file path of an old module: ``excavsim/loop/drags.py`` -> ``excavsim/studies/figures/drags.py``.

Re-runnable and idempotent: no new name contains an old one, so a second run changes nothing.
"""

from __future__ import annotations

import argparse
import pathlib
import re
import sys

# Old module -> new module. Keep it: branches written before the move still use the old names.
MODULES: dict[str, str] = {
    # tasks: one home per task
    "excavsim.loop.loading": "excavsim.tasks.pile_loading.planar",
    "excavsim.loop.loading_mujoco": "excavsim.tasks.pile_loading.task",
    "excavsim.tasks.pile_loading.in_mujoco": "excavsim.tasks.pile_loading.task",  # split: its campaigns went to load.campaign (NAMES)
    "excavsim.loop.truck": "excavsim.tasks.dump_trial.trial",
    "excavsim.loop.truck_campaign": "excavsim.tasks.dump_trial.campaign",
    # trenching, out of the platform (loop.episode's and loop.digs' trenching names moved by name:
    # see NAMES below)
    "excavsim.loop.demo": "excavsim.tasks.trench.demo",
    "excavsim.loop.online": "excavsim.tasks.trench.online",
    "excavsim.loop.plan_dig": "excavsim.tasks.trench.plan_dig",
    "excavsim.loop.timing": "excavsim.tasks.trench.timing",
    # applications
    "excavsim.loop.playback": "excavsim.apps.playback.driver",
    "excavsim.apps.playback.play": "excavsim.apps.playback.driver",  # one driver for any machine (issue 41)
    "excavsim.loop.teleop": "excavsim.apps.playback.teleop",
    "excavsim.loop.calibrate": "excavsim.apps.calibrate.fit",
    "excavsim.loop.calibrate_digs": "excavsim.apps.calibrate.digs",
    # studies
    "excavsim.loop.campaign": "excavsim.studies.campaign.runner",
    "excavsim.loop.campaign_grid": "excavsim.studies.campaign.grid",
    "excavsim.loop.campaign_report": "excavsim.studies.campaign.report",
    "excavsim.loop.regress": "excavsim.studies.regress.suite",
    "excavsim.loop.regress_stats": "excavsim.studies.regress.stats",
    "excavsim.loop.against": "excavsim.studies.regress.against",
    "excavsim.loop.experiment": "excavsim.studies.experiment",
    "excavsim.loop.figures": "excavsim.studies.figures.thesis",
    "excavsim.loop.figures_plan": "excavsim.studies.figures.plan",
    "excavsim.loop.drags": "excavsim.studies.figures.drags",
    "excavsim.loop.learn": "excavsim.studies.learning.compare",
    "excavsim.loop.collect": "excavsim.studies.learning.collect",
    "excavsim.bench": "excavsim.studies.bench",
    # issue 41: what one task alone uses moved into its folder, split by side (tasks/<task>/world: truth;
    # tasks/<task>/mind: the robot's mind)
    "excavsim.world.loading_scene": "excavsim.tasks.pile_loading.world.scene",
    "excavsim.world.pile2d": "excavsim.tasks.pile_loading.world.pile2d",
    "excavsim.planning.loading": "excavsim.tasks.pile_loading.mind.planner",
    "excavsim.execution.loading_script": "excavsim.tasks.pile_loading.mind.script",
    "excavsim.world.truck": "excavsim.tasks.truck_loading.world.truck",
    "excavsim.planning.truck_loading": "excavsim.tasks.truck_loading.mind.planner",
    "excavsim.execution.autodig": "excavsim.tasks.truck_loading.mind.autodig",
    "excavsim.planning.fallback": "excavsim.tasks.trench.mind.fallback",
    "tests.execution.test_autodig": "tests.tasks.truck_loading.test_autodig",
    "tests.planning.test_fallback": "tests.tasks.trench.test_fallback",
}

# Tests mirror the package tree: test module -> its folder under tests/ (issue 32, deliverable 7).
TESTS: dict[str, str] = {
    **dict.fromkeys(["test_action", "test_anneal", "test_constraints", "test_experience",
                     "test_feasibility", "test_objectives", "test_plan_figures", "test_planner_kernel",
                     "test_search"], "planning"),
    **dict.fromkeys(["test_fast", "test_kinematics", "test_reachability", "test_statics"], "robot"),
    **dict.fromkeys(["test_dimaio", "test_models", "test_references", "test_settle", "test_soil",
                     "test_soil_mechanics", "test_soil_perf", "test_soil_variability"], "world"),
    "test_wedge": "mechanics",
    **dict.fromkeys(["test_ft", "test_sensing"], "sensing"),
    **dict.fromkeys(["test_compiled_executor", "test_execution", "test_watchdog"], "execution"),
    "test_learning": "learning",
    **dict.fromkeys(["test_record", "test_viewer"], "record"),
    "test_config": "config",
    **dict.fromkeys(["test_cycle", "test_episode"], "loop"),
    **dict.fromkeys(["test_demo", "test_table7", "test_fallback"], "tasks/trench"),
    "test_envs": "envs",
    "test_cli_errors": "cli",
    **dict.fromkeys(["test_loading", "test_loading_mujoco"], "tasks/pile_loading"),
    **dict.fromkeys(["test_truck", "test_truck_tuning"], "tasks/dump_trial"),
    **dict.fromkeys(["test_calibrate", "test_calibrate_noise", "test_identify"], "apps/calibrate"),
    **dict.fromkeys(["test_playback", "test_playback_duality", "test_playback_seeds", "test_playback_sources"],
                    "apps/playback"),
    **dict.fromkeys(["test_bench", "test_experiment"], "studies"),
    **dict.fromkeys(["test_campaign", "test_campaign_hygiene"], "studies/campaign"),
    "test_regress": "studies/regress",
    "test_figures": "studies/figures",
}
MODULES.update({f"tests.{name}": f"tests.{folder.replace('/', '.')}.{name}" for name, folder in TESTS.items()})

# Old name -> new name, for the modules that were split rather than moved: trenching's names left the
# platform's loop.episode and loop.digs for excavsim.tasks.trench (Episode, Task, MapWriter, Choice and
# DigSource stayed; the trench's privileged measures went to loop.measures, the demo's action to handoff).
NAMES: dict[str, str] = {
    **{f"excavsim.loop.episode.{n}": f"excavsim.tasks.trench.task.{n}" for n in ("TrenchTask", "run_episode", "map_done")},
    # a dig's metrics, then in the trench task, serve every task that digs with the rig
    **{f"{old}.{n}": f"excavsim.rig.measures.{n}" for old in ("excavsim.loop.episode", "excavsim.tasks.trench.task")
       for n in ("dig_metrics", "MIN_USEFUL_M3")},
    **{f"excavsim.loop.episode.{n}": f"excavsim.loop.measures.{n}" for n in ("trench_footprint", "episode_result")},
    **{f"excavsim.loop.digs.{n}": f"excavsim.tasks.trench.digs.{n}"
       for n in ("PlannedDigs", "RandomFeasibleDigs", "ScriptedDigs", "predicted_peaks", "relaxed_margins",
                 "OVER_LIMIT_MARGINS")},
    "excavsim.loop.demo.DEMO_ACTION": "excavsim.handoff.dig.DEMO_ACTION",
    # loading in MuJoCo: the task stayed (tasks.load.task), its runs over machines and seeds left it
    **{f"{old}.{n}": f"excavsim.tasks.pile_loading.campaign.{n}"
       for old in ("excavsim.loop.loading_mujoco", "excavsim.tasks.pile_loading.in_mujoco")
       for n in ("format_comparison", "load_campaign", "same_pile_2d", "run_campaign", "format_campaign",
                 "write_campaign", "run_episodes")},
    # calibration: the fits stayed (apps.calibrate.fit), the command's run and Table 5.3's experiment left it
    **{f"{old}.{n}": f"excavsim.apps.calibrate.run.{n}"
       for old in ("excavsim.loop.calibrate", "excavsim.apps.calibrate.fit")
       for n in ("RERUN_LAG_S", "Rerun", "rerun", "calibrate", "calibrate_file")},
    **{f"{old}.record_digs": "excavsim.apps.calibrate.digs.record_digs"
       for old in ("excavsim.loop.calibrate", "excavsim.apps.calibrate.fit", "excavsim.apps.calibrate.run")},
    **{f"{old}.{n}": f"excavsim.apps.calibrate.table53.{n}"
       for old in ("excavsim.loop.calibrate", "excavsim.apps.calibrate.fit")
       for n in ("TABLE_5_3_THESIS", "table_5_3")},
}

# Literal strings that are neither module names nor module paths (git pathspecs in tests).
LITERALS: dict[str, str] = {
    "excavsim/loop/regress*.py": "excavsim/studies/regress",
    "loop/campaign*.py": "studies/campaign/",
}

SUFFIXES = {".py", ".md", ".toml", ".yaml", ".yml", ".txt", ".cfg", ".rst", ".ini"}
DEFAULT_TARGETS = ["excavsim", "tests", "scripts", "examples", "docs", "configs", "README.md", "pyproject.toml",
                   "Makefile", ".ci", "models"]
SKIP_DIRS = {".git", ".venv", "__pycache__", "node_modules", "build", "dist", ".mypy_cache", ".pytest_cache"}


def _path(module: str) -> str:
    return module.replace(".", "/") + ".py"


PATHS = {_path(old): _path(new) for old, new in MODULES.items()}
# the same paths relative to the package (``loop/drags.py`` in docs/architecture.md's tables)
PATHS.update({k.removeprefix("excavsim/"): v.removeprefix("excavsim/") for k, v in list(PATHS.items())
              if k.startswith(("excavsim/loop/", "excavsim/world/", "excavsim/planning/", "excavsim/execution/"))})

_NAME = r"[A-Za-z_][\w.]*"
# longest first, so that excavsim.loop.campaign_grid is not read as excavsim.loop.campaign + "_grid"
_DOTTED = re.compile(r"(?<![\w.])(" + "|".join(re.escape(k) for k in sorted(MODULES, key=len, reverse=True))
                     + r")(?![\w])")
_NAMES = re.compile(r"(?<![\w.])(" + "|".join(re.escape(k) for k in sorted(NAMES, key=len, reverse=True))
                    + r")(?![\w])")
_PATHS = re.compile(r"(?<![\w/.])(" + "|".join(re.escape(k) for k in sorted(PATHS, key=len, reverse=True)) + r")")
_FROM = re.compile(r"^(?P<indent>[ \t]*)from[ \t]+(?P<pkg>" + _NAME + r")[ \t]+import[ \t]+"
                   r"(?P<names>\([^)]*\)|[^\n#;]*?)(?P<tail>[ \t]*(#[^\n]*)?)$", re.MULTILINE)


# tests that imported each other by bare name (tests/ on sys.path): ``import test_execution as te``
_BARE_TEST = re.compile(r"^(?P<indent>[ \t]*)"
                        r"(?:import (?P<mod>test_\w+)(?P<alias> as \w+)?|from (?P<frm>test_\w+) import)", re.MULTILINE)


def _rewrite_bare_test(match: re.Match[str]) -> str:
    name = match["mod"] or match["frm"]
    if name not in TESTS:
        return match.group(0)
    package = "tests." + TESTS[name].replace("/", ".")
    if match["mod"]:
        return f"{match['indent']}from {package} import {name}" + (match["alias"] or "")
    return f"{match['indent']}from {package}.{name} import"


def _rewrite_from(match: re.Match[str]) -> str:
    """``from PKG import a, b as c`` with moved modules among the names -> one statement per home."""
    indent, pkg, names = match["indent"], match["pkg"], match["names"]
    parens = names.startswith("(")
    body = names[1:-1] if parens else names
    items = [i.strip() for i in body.replace("\\\n", " ").split(",") if i.strip()]
    kept, moved = [], []
    homes: dict[str, list[str]] = {}  # a split module's names, by their new module
    for item in items:
        name, _, alias = (p.strip() for p in item.partition(" as "))
        if f"{pkg}.{name}" in NAMES:
            homes.setdefault(NAMES[f"{pkg}.{name}"].rsplit(".", 1)[0], []).append(item)
            continue
        new = MODULES.get(f"{pkg}.{name}")
        if new is None:
            kept.append(item)
            continue
        parent, base = new.rsplit(".", 1)
        local = alias or name
        moved.append(f"{indent}from {parent} import {base}" + (f" as {local}" if local != base else ""))
    moved += [f"{indent}from {home} import {', '.join(names)}" for home, names in homes.items()]
    if not moved:
        return match.group(0)
    lines = []
    if kept:
        names = ", ".join(kept)
        lines.append(f"{indent}from {pkg} import " + (f"({names})" if parens and len(kept) > 1 else names)
                     + match["tail"])
    elif match["tail"].strip():
        moved[0] += match["tail"]
    return "\n".join(lines + moved)


def rewrite(text: str) -> str:
    """The text with every old module name, import and path replaced by the new one."""
    text = _FROM.sub(_rewrite_from, text)
    text = _BARE_TEST.sub(_rewrite_bare_test, text)
    text = _NAMES.sub(lambda m: NAMES[m.group(1)], text)
    text = _DOTTED.sub(lambda m: MODULES[m.group(1)], text)
    text = _PATHS.sub(lambda m: PATHS[m.group(1)], text)
    for old, new in LITERALS.items():
        text = text.replace(old, new)
    return text


def _files(targets: list[str]) -> list[pathlib.Path]:
    me = pathlib.Path(__file__).resolve()
    out = []
    for target in targets:
        path = pathlib.Path(target)
        if not path.exists():
            continue
        candidates = [path] if path.is_file() else sorted(p for p in path.rglob("*") if p.is_file())
        for p in candidates:
            if SKIP_DIRS & set(p.parts) or p.resolve() == me:
                continue
            if p.suffix in SUFFIXES or p.name == "Makefile" or (p.is_file() and path.name == ".ci"):
                out.append(p)
    return out


def main(argv: list[str] | None = None) -> int:
    """Rewrites the given files (or the default set) in place; ``--check`` only lists them."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("targets", nargs="*", help=f"files or folders (default: {' '.join(DEFAULT_TARGETS)})")
    parser.add_argument("--check", action="store_true", help="change nothing; exit 1 if a file would change")
    args = parser.parse_args(argv)
    changed = []
    for path in _files(args.targets or DEFAULT_TARGETS):
        try:
            text = path.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            continue
        new = rewrite(text)
        if new != text:
            changed.append(path)
            if not args.check:
                path.write_text(new, encoding="utf-8")
    for path in changed:
        print(("would rewrite " if args.check else "rewrote ") + str(path))
    return 1 if (args.check and changed) else 0


if __name__ == "__main__":
    sys.exit(main())
