"""The thesis' trenching experiments by command (Singh 1995 §7.2.2, Figs. 113-117).

An experiment (``configs/experiments/*.yaml``, :class:`ExperimentSpec`) is one or more trenching
episodes (:class:`~excavsim.loop.scenario.EpisodeSpec`) with the planner's constraints and
objective set as the thesis ran them, and the thesis' own account of what it saw. Running one
(:func:`run_experiment`, ``excavsim experiment NAME``) writes into its directory:

* ``sections.png``: the section of the elevation map through the trench (in the arm plane) after
  every dig, one small panel per dig as the thesis draws its sequences, with the goal (dashed) and
  the true terrain (thin, which the planner never sees);
* ``digs.csv`` and ``digs.txt``: the table of digs of every run;
* ``summary.txt``: the runs side by side (digs, litres per dig, stalls, failed digs, soil removed,
  how the episode ended), under the thesis' account.

:func:`format_comparison` puts several experiments' summaries side by side (``excavsim experiment
all``).
"""

from __future__ import annotations

import csv
import dataclasses
import math
import pathlib
from collections.abc import Callable

import numpy as np
from pydantic import Field

from excavsim import constants
from excavsim.config import ConfigError, StrictModel, load_config
from excavsim.handoff.episode import EpisodeObserver, EpisodeResult, format_episode
from excavsim.handoff.goal import goal_profile
from excavsim.loop.scenario import EpisodeSpec, dig_rows, resolve, run_spec

EXPERIMENTS_DIR = constants.CONFIGS_DIR / "experiments"
_SECTION_SAMPLES = 241  # points along the section [-]


class ExperimentSpec(StrictModel):
    """One experiment of §7.2.2: its runs and what the thesis reports for it."""

    name: str = Field(description="short name, the file's stem (e.g. fig113)")
    title: str = Field(description="what the experiment is, as the thesis' caption says it")
    thesis: str = Field(description="what the thesis reports for it (its text, not its figure)")
    runs: list[EpisodeSpec] = Field(min_length=1, description="the episodes, each with its seed and overrides")


def experiment_names() -> list[str]:
    """The experiments of ``configs/experiments``, by name."""
    return sorted(p.stem for p in EXPERIMENTS_DIR.glob("*.yaml"))


def load_experiment(name_or_path: str | pathlib.Path) -> ExperimentSpec:
    """The experiment named ``name_or_path`` in ``configs/experiments``, or the YAML file at that path.

    Raises:
        ConfigError: no such experiment (the message lists the known ones) or an invalid file.
    """
    path = pathlib.Path(name_or_path)
    if path.suffix not in (".yaml", ".yml"):
        path = EXPERIMENTS_DIR / f"{name_or_path}.yaml"
    if not path.is_file():
        raise ConfigError(f"no experiment {str(name_or_path)!r}; known: {', '.join(experiment_names())} "
                          f"(or a path to a YAML file)")
    return load_config(path, ExperimentSpec)


@dataclasses.dataclass
class Section:
    """The trench's section in the arm plane after one dig (or before the first, ``dig`` 0)."""

    dig: int
    map_z: np.ndarray  # the scanned elevation map [m] (NaN where unknown)
    true_z: np.ndarray  # the world's terrain [m]


class SectionRecorder(EpisodeObserver):
    """Takes the section through the trench from every scanned map, and the true terrain's beside it.

    Args:
        r: radial distances of the section's points from the waist axis [m].
    """

    def __init__(self, r: np.ndarray):
        self.r = np.asarray(r, dtype=float)
        self.sections: list[Section] = []

    def started(self, sim, rig, goal_mask, goal_z) -> None:
        self.sim = sim
        w = math.radians(rig.goal.waist_deg)
        self.x, self.y = self.r * math.cos(w), self.r * math.sin(w)

    def scanned(self, index, emap, accuracy) -> None:
        z_map = np.asarray(emap.height_at(self.x, self.y), dtype=float)
        z_true = np.asarray(self.sim.soil.grid.surface_z(self.x, self.y), dtype=float)
        self.sections.append(Section(len(self.sections), z_map, z_true))


@dataclasses.dataclass
class RunResult:
    """One run of an experiment: its spec, the episode and the sections after each dig."""

    spec: EpisodeSpec
    result: EpisodeResult
    r: np.ndarray
    sections: list[Section]


def run_experiment(exp: ExperimentSpec, out: str | pathlib.Path, *,
                   progress: Callable[[str], None] | None = None) -> list[RunResult]:
    """Run every episode of ``exp`` and write its figure, tables and summary into ``out``.

    Each run's files are written as soon as it ends, so a failure in a later run loses nothing.
    """
    say = progress or (lambda _s: None)
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    runs: list[RunResult] = []
    for i, spec in enumerate(exp.runs):
        goal = resolve(spec).goal  # an experiment's runs dig goals (a trench's); their task resolves them
        r = np.linspace(max(0.6, goal.near_x_m - 0.6), min(3.5, goal.far_x_m + 0.6), _SECTION_SAMPLES)
        recorder = SectionRecorder(r)
        say(f"[{exp.name} run {i + 1}/{len(exp.runs)}] {spec.name}: seed {spec.seed}")
        result = run_spec(spec, observer=recorder, progress=lambda s: say("  " + s))
        runs.append(RunResult(spec, result, r, recorder.sections))
        write_outputs(exp, runs, out)
    return runs


def run_experiments(names: list[str], out: str | pathlib.Path, *, dig_budget: int | None = None, seeds: int = 1,
                    verbose: bool = False, say: Callable[[str], None] = print) -> None:
    """``excavsim experiment NAME...``: run the named experiments (``["all"]``: every one of
    ``configs/experiments``), each into ``out/NAME``, and with several, or with ``seeds > 1``, a
    comparison table (``out/comparison.txt``).

    Args:
        names: experiment names or YAML files; every one is checked before anything runs.
        dig_budget: overrides every run's dig budget.
        seeds: every run once per seed: its seed, then on by the number of runs (fig114's two runs
            from seeds 0 and 1 get 0, 2, 4, ... and 1, 3, 5, ...: never the same episode twice).
        verbose: say every scan and dig.
        say: where the summaries go.
    """
    names = experiment_names() if names == ["all"] else names
    specs = [load_experiment(n) for n in names]
    if dig_budget is not None:
        specs = [s.model_copy(update={"runs": [r.model_copy(update={"dig_budget": dig_budget}) for r in s.runs]})
                 for s in specs]
    if seeds > 1:
        def reseeded(r, i, stride):
            seed = r.seed + i * stride
            return r.model_copy(update={"seed": seed, "name": f"{r.name}-s{seed}"})

        specs = [s.model_copy(update={"runs": [reseeded(r, i, len(s.runs)) for r in s.runs
                                               for i in range(seeds)]}) for s in specs]
    out = pathlib.Path(out)
    results = {}
    for exp in specs:
        say(f"excavsim experiment {exp.name}: {exp.title}")
        runs = run_experiment(exp, out / exp.name, progress=say if verbose else None)
        results[exp.name] = (exp, runs)
        say((out / exp.name / "summary.txt").read_text())
        say(f"wrote {out / exp.name}/sections.png, digs.csv, digs.txt, summary.txt\n")
    if len(results) > 1 or seeds > 1:
        table = format_comparison(results) + "\n\npooled over each experiment's runs:\n" + format_means(results)
        (out / "comparison.txt").write_text(table + "\n")
        say(table)
        say(f"wrote {out / 'comparison.txt'}")


def write_outputs(exp: ExperimentSpec, runs: list[RunResult], out: pathlib.Path) -> list[pathlib.Path]:
    """Write ``sections.png``, ``digs.csv``, ``digs.txt`` and ``summary.txt`` of the runs so far."""
    paths = [plot_sections(exp, runs, out / "sections.png")]
    rows = [{"run": i + 1, "seed": run.spec.seed, **row} for i, run in enumerate(runs) for row in dig_rows(run.result, run.spec.task)]
    with open(out / "digs.csv", "w", newline="") as f:
        if rows:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows({k: f"{v:.4g}" if isinstance(v, float) else v for k, v in row.items()} for row in rows)
    paths.append(out / "digs.csv")
    (out / "digs.txt").write_text("\n\n".join(f"run {i + 1} ({run.spec.name}, seed {run.spec.seed})"
                                              + format_episode(run.result) for i, run in enumerate(runs)) + "\n")
    paths.append(out / "digs.txt")
    (out / "summary.txt").write_text(format_summary(exp, runs) + "\n")
    paths.append(out / "summary.txt")
    return paths


def run_row(run: RunResult) -> dict[str, str]:
    """One run's numbers for a summary table, formatted."""
    res = run.result
    n = len(res.digs)
    planned = [d for d in res.digs if d.action is not None]
    return {
        "seed": str(run.spec.seed),
        "digs": str(n),
        "l/dig": f"{1000 * res.removed_m3 / n:.1f}" if n else "-",
        "dug l/dig": f"{1000 * np.mean([d.bucket_m3 for d in res.digs]):.1f}" if n else "-",
        "stalls": str(sum(d.stall_joint is not None for d in res.digs)),
        "failed": str(sum(d.failed for d in res.digs)),
        "alpha deg": f"{np.mean([math.degrees(d.action[1]) for d in planned]):.0f}" if planned else "-",
        "d2 m": f"{np.mean([d.action[3] for d in planned]):.2f}" if planned else "-",
        "wrist peak": f"{np.mean([d.peak_torque_nm[3] for d in res.digs]):.0f}" if n else "-",
        "removed %": f"{100 * res.removed_fraction:.0f}",
        "end": res.end,
    }


def _table(header: list[str], rows: list[list[str]]) -> str:
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(header)]

    def fmt(cells: list[str]) -> str:
        return "  ".join(c.rjust(w) if i else c.ljust(w) for i, (c, w) in enumerate(zip(cells, widths)))

    return "\n".join([fmt(header)] + [fmt(r) for r in rows])


def format_summary(exp: ExperimentSpec, runs: list[RunResult]) -> str:
    """The runs of one experiment side by side, under the thesis' account."""
    rows = [[f"run {i + 1}", *run_row(run).values()] for i, run in enumerate(runs)]
    header = ["", *run_row(runs[0]).keys()]
    return "\n".join([f"{exp.name}: {exp.title}", "", "thesis: " + exp.thesis, "", _table(header, rows), "",
                      "l/dig: soil removed from the goal per dig; dug l/dig: soil in the bucket at lift-out; "
                      "alpha, d2: mean over planned digs; wrist peak: mean measured peak wrist-pitch torque [N m]"])


def format_comparison(results: dict[str, tuple[ExperimentSpec, list[RunResult]]]) -> str:
    """Several experiments' runs side by side (one row per run)."""
    rows, header = [], None
    for name, (exp, runs) in results.items():
        for i, run in enumerate(runs):
            row = run_row(run)
            header = header or ["experiment", *row.keys()]
            rows.append([f"{name}" + (f" run {i + 1}" if len(runs) > 1 else ""), *row.values()])
    return _table(header, rows) if rows else "(no runs)"


def format_means(results: dict[str, tuple[ExperimentSpec, list[RunResult]]]) -> str:
    """Each experiment's runs pooled (one row per experiment): for comparisons over several seeds."""
    header = ["experiment", "runs", "digs/run", "l/dig", "dug l/dig", "stalls/run", "failed %", "alpha deg",
              "d2 m", "removed %", "done"]
    rows = []
    for name, (_, runs) in results.items():
        digs = [d for run in runs for d in run.result.digs]
        planned = [d for d in digs if d.action is not None]
        n = max(len(digs), 1)
        rows.append([name, str(len(runs)), f"{len(digs) / len(runs):.1f}",
                     f"{1000 * sum(r.result.removed_m3 for r in runs) / n:.1f}",
                     f"{1000 * np.mean([d.bucket_m3 for d in digs]) if digs else math.nan:.1f}",
                     f"{sum(d.stall_joint is not None for d in digs) / len(runs):.2f}",
                     f"{100 * sum(d.failed for d in digs) / n:.0f}",
                     f"{np.mean([math.degrees(d.action[1]) for d in planned]) if planned else math.nan:.0f}",
                     f"{np.mean([d.action[3] for d in planned]) if planned else math.nan:.2f}",
                     f"{100 * np.mean([r.result.removed_fraction for r in runs]):.0f}",
                     f"{sum(r.result.end == 'done' for r in runs)}/{len(runs)}"])
    return _table(header, rows) if rows else "(no runs)"


def plot_sections(exp: ExperimentSpec, runs: list[RunResult], path: str | pathlib.Path, *,
                  ncols: int = 6) -> pathlib.Path:
    """Draw the section after every dig, one panel per dig, one block of panels per run.

    Each panel shows the map's section after that dig (solid), the one before it (grey), the true
    terrain (thin, dotted) and the goal (dashed); its title gives the dig's action and outcome.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    blocks = []
    for run in runs:
        n = max(len(run.sections) - 1, 1)
        blocks.append(math.ceil(n / ncols))
    nrows = sum(blocks)
    fig = Figure(figsize=(2.4 * ncols, 1.7 * nrows + 1.0))
    FigureCanvasAgg(fig)
    row0 = 0
    for b, run in zip(blocks, runs):
        goal = resolve(run.spec).goal
        z_goal = goal_profile(goal, run.r)
        digs = {d.index: d for d in run.result.digs}
        lo = min(np.nanmin(z_goal), *(np.nanmin(s.true_z) for s in run.sections)) - 0.03
        hi = max(np.nanmax(s.map_z) for s in run.sections) + 0.03
        for j, sec in enumerate(run.sections[1:] or run.sections[:1]):
            ax = fig.add_subplot(nrows, ncols, row0 * ncols + j + 1)
            before = run.sections[j]
            ax.plot(run.r, before.map_z, color="#bbbbbb", lw=0.8)
            ax.plot(run.r, sec.true_z, color="#8c564b", lw=0.6, ls=":")
            ax.plot(run.r, z_goal, color="#d62728", lw=0.8, ls="--")
            ax.plot(run.r, sec.map_z, color="#1f77b4", lw=1.2)
            ax.set_ylim(lo, hi)
            d = digs.get(sec.dig)
            if d is not None:
                if d.action is not None:
                    k, a, d1, d2 = d.action
                    act = f"k {k:.1f} a {math.degrees(a):.0f} d1 {d1:.2f} d2 {d2:.2f}"
                else:
                    act = d.kind
                tag = d.failure or f"{1000 * d.bucket_m3:.0f} l"
                ax.set_title(f"{sec.dig}: {act}\n{tag}", fontsize=6)
            ax.tick_params(labelsize=5)
            if j % ncols == 0:
                ax.set_ylabel(f"run {runs.index(run) + 1}\nz [m]", fontsize=6)
        row0 += b
    fig.suptitle(f"{exp.name}: {exp.title}\nmap section after each dig (blue), before it (grey), true terrain "
                 "(dotted), goal (dashed); x: distance from the waist axis [m]", fontsize=9)
    fig.subplots_adjust(left=0.05, right=0.99, top=1 - 0.9 / (1.7 * nrows + 1.0), bottom=0.04, wspace=0.3,
                        hspace=0.9)
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    return path
